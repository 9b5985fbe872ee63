//! Decoding the firmware's defmt log (semihosting output under QEMU) with the ELF's table.

use defmt_decoder::{DecodeError, Table};

/// Decodes a complete defmt byte stream into one text line per log message.
pub fn decode(elf: &[u8], bytes: &[u8]) -> Result<Vec<String>, String> {
    let table = Table::parse(elf)
        .map_err(|e| format!("defmt table: {e}"))?
        .ok_or("the ELF has no defmt table (was it built with defmt?)")?;
    let mut decoder = table.new_stream_decoder();
    let mut lines = Vec::new();
    // In small pieces: the decoder shifts its buffer after every frame, which is
    // quadratic on a long log (a 60-minute soak is 20 MB) handed over at once.
    for chunk in bytes.chunks(4096) {
        decoder.received(chunk);
        loop {
            match decoder.decode() {
                Ok(frame) => lines.push(frame.display_message().to_string()),
                Err(DecodeError::UnexpectedEof) => break,
                Err(DecodeError::Malformed) => {
                    return Err(format!(
                        "malformed defmt frame after {} messages",
                        lines.len()
                    ))
                }
            }
        }
    }
    Ok(lines)
}
