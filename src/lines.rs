//! Line-oriented input in bounded memory: one line at a time, each at most [`MAX_LINE_BYTES`],
//! with a line that is too long or not UTF-8 reported as that line's error (by its 1-based
//! number) instead of ending the input.

use std::io::BufRead;

/// Longest line kept, in bytes; the rest of a longer line is skipped without being stored.
pub const MAX_LINE_BYTES: usize = 1 << 16;

/// The lines of a reader: `(number, Ok(text) | Err(why the line is unusable))`, or an I/O error.
pub struct Lines<R> {
    reader: R,
    number: usize,
    buf: Vec<u8>,
}

/// The lines of `reader` (see [`Lines`]).
pub fn lines<R: BufRead>(reader: R) -> Lines<R> {
    Lines {
        reader,
        number: 0,
        buf: Vec::new(),
    }
}

impl<R: BufRead> Lines<R> {
    fn read(&mut self) -> std::io::Result<Option<(usize, Result<String, String>)>> {
        self.buf.clear();
        let mut seen = false;
        let mut too_long = false;
        loop {
            let avail = match self.reader.fill_buf() {
                Ok(a) => a,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            if avail.is_empty() {
                if !seen {
                    return Ok(None);
                }
                break;
            }
            seen = true;
            let (chunk, used, end) = match avail.iter().position(|&b| b == b'\n') {
                Some(i) => (&avail[..i], i + 1, true),
                None => (avail, avail.len(), false),
            };
            let room = MAX_LINE_BYTES.saturating_sub(self.buf.len());
            if chunk.len() > room {
                too_long = true;
            }
            self.buf.extend_from_slice(&chunk[..chunk.len().min(room)]);
            self.reader.consume(used);
            if end {
                break;
            }
        }
        self.number += 1;
        if too_long {
            return Ok(Some((
                self.number,
                Err(format!("line longer than {MAX_LINE_BYTES} bytes")),
            )));
        }
        if self.buf.last() == Some(&b'\r') {
            self.buf.pop();
        }
        let text = match std::str::from_utf8(&self.buf) {
            Ok(t) => Ok(t.to_string()),
            Err(e) => Err(format!("invalid UTF-8 at byte {}", e.valid_up_to() + 1)),
        };
        Ok(Some((self.number, text)))
    }
}

impl<R: BufRead> Iterator for Lines<R> {
    type Item = std::io::Result<(usize, Result<String, String>)>;

    fn next(&mut self) -> Option<Self::Item> {
        self.read().transpose()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_lines_are_reported_and_the_rest_read() {
        let mut input = b"1 2 3\r\n\xff\xfe x\n".to_vec();
        input.extend(std::iter::repeat_n(b'a', MAX_LINE_BYTES + 10));
        input.extend_from_slice(b"\nlast");
        let got: Vec<_> = lines(std::io::Cursor::new(input))
            .map(|l| l.unwrap())
            .collect();
        assert_eq!(
            got,
            vec![
                (1, Ok("1 2 3".to_string())),
                (2, Err("invalid UTF-8 at byte 1".to_string())),
                (3, Err(format!("line longer than {MAX_LINE_BYTES} bytes"))),
                (4, Ok("last".to_string())),
            ]
        );
        assert_eq!(lines(std::io::Cursor::new(b"")).count(), 0);
        assert_eq!(lines(std::io::Cursor::new(b"\n")).count(), 1);
    }
}
