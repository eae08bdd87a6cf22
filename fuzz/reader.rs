//! The fuzzer's bytes, read front to back: the one reader of every target's input decoding
//! (both fuzz workspaces include this file, `fuzz/src/lib.rs` and `fuzz/runtime/src/lib.rs`,
//! and so does `tests/tests/e2e/fuzz_replay.rs`).

/// The fuzzer's bytes, read front to back; zeros once exhausted.
pub struct Reader<'a>(pub &'a [u8]);

impl Reader<'_> {
    pub fn done(&self) -> bool {
        self.0.is_empty()
    }
    pub fn byte(&mut self) -> u8 {
        let (&b, rest) = self.0.split_first().unwrap_or((&0, &[]));
        self.0 = rest;
        b
    }
    pub fn u16(&mut self) -> u16 {
        u16::from_le_bytes([self.byte(), self.byte()])
    }
    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.byte(), self.byte(), self.byte(), self.byte()])
    }
    pub fn u64(&mut self) -> u64 {
        u64::from_le_bytes(std::array::from_fn(|_| self.byte()))
    }
    pub fn take(&mut self, n: usize) -> &[u8] {
        let (taken, rest) = self.0.split_at(n.min(self.0.len()));
        self.0 = rest;
        taken
    }
}
