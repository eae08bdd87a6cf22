//! The `lrr` binary: everything lives in the `lrr_cli` library (`lrr_cli::run`); this prints the error chain on
//! one line and sets the exit code.

fn main() {
    let mut stdout = std::io::stdout().lock();
    if let Err(e) = lrr_cli::run(std::env::args_os(), &mut stdout) {
        // A closed pipe (`lrr info x.lrr | head`) is not a failure.
        let broken_pipe = e.chain().any(|c| {
            c.downcast_ref::<std::io::Error>()
                .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
        });
        if broken_pipe {
            return;
        }
        let chain: Vec<String> = e.chain().map(|c| c.to_string()).collect();
        eprintln!("lrr: error: {}", chain.join(": "));
        std::process::exit(1);
    }
}
