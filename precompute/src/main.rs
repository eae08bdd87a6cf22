//! The `lrr` binary: everything lives in `lrr_precompute::cli`; this prints the error chain on
//! one line and sets the exit code.

fn main() {
    let mut stdout = std::io::stdout().lock();
    if let Err(e) = lrr_precompute::cli::run(std::env::args_os(), &mut stdout) {
        let chain: Vec<String> = e.chain().map(|c| c.to_string()).collect();
        eprintln!("lrr: error: {}", chain.join(": "));
        std::process::exit(1);
    }
}
