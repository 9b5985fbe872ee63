//! Standard output of the command-line tools (`study`, `ecu --reference`).

use std::io::{self, Write};

/// Writes `text` to standard output. A closed pipe (`study … | head`, `ecu --reference …
/// | head`) ends the program quietly, exit status 0, as it ends other Unix tools, instead
/// of panicking in `println!` (exit status 101).
pub fn emit(text: &str) -> Result<(), String> {
    let mut out = io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == io::ErrorKind::BrokenPipe => std::process::exit(0),
        Err(e) => Err(format!("standard output: {e}")),
    }
}
