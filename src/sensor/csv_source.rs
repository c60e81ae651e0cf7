//! The byte stream the `csv` crate reads, with the recording format's `#` lines taken out.
//!
//! A recording's `# key=value` lines may stand anywhere, and a comment may hold a lone quote
//! (`# 5" weight`) that would swallow the rows after it if the CSV parser saw it. This reader
//! hands the parser every line as it is, except that a `#` line becomes an empty line (so the
//! parser's line numbers stay the file's) and is kept, with its line number, for the metadata.
//! It streams: one line is held at a time.

use std::io::{BufRead, Read};

pub struct CommentTee<R> {
    inner: R,
    line: Vec<u8>,
    /// Bytes of the current line not yet handed out.
    pending: std::ops::Range<usize>,
    n: usize,
    /// The `#` lines so far: (1-based line, text after the '#').
    pub comments: Vec<(usize, String)>,
    /// The first line that is not UTF-8 (reading stops there).
    pub not_text: Option<usize>,
}

impl<R: BufRead> CommentTee<R> {
    pub fn new(inner: R) -> Self {
        CommentTee { inner, line: Vec::new(), pending: 0..0, n: 0, comments: Vec::new(), not_text: None }
    }

    /// Reads the next line into `self.line`, replacing a comment line by "\n". False at the end.
    fn next_line(&mut self) -> std::io::Result<bool> {
        if self.not_text.is_some() {
            return Ok(false);
        }
        self.line.clear();
        if self.inner.read_until(b'\n', &mut self.line)? == 0 {
            return Ok(false);
        }
        self.n += 1;
        // a spreadsheet's "CSV UTF-8" starts with a byte-order mark
        if self.n == 1 && self.line.starts_with(b"\xef\xbb\xbf") {
            self.line.drain(..3);
        }
        let Ok(text) = std::str::from_utf8(&self.line) else {
            self.not_text = Some(self.n);
            self.line.clear();
            return Ok(false);
        };
        if let Some(c) = text.trim_start().strip_prefix('#') {
            self.comments.push((self.n, c.trim_end().to_string()));
            self.line.clear();
            self.line.push(b'\n');
        }
        self.pending = 0..self.line.len();
        Ok(true)
    }
}

impl<R: BufRead> Read for CommentTee<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        while self.pending.is_empty() {
            if !self.next_line()? {
                return Ok(0);
            }
        }
        let k = buf.len().min(self.pending.len());
        buf[..k].copy_from_slice(&self.line[self.pending.start..self.pending.start + k]);
        self.pending.start += k;
        Ok(k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comments_are_kept_with_their_lines_and_blanked_for_the_parser() {
        let src = "\u{feff}# a=1\ntime_s,v\n# 5\" weight\n0,1\n";
        let mut tee = CommentTee::new(src.as_bytes());
        let mut out = String::new();
        tee.read_to_string(&mut out).unwrap();
        assert_eq!(out, "\ntime_s,v\n\n0,1\n");
        assert_eq!(tee.comments, vec![(1, " a=1".to_string()), (3, " 5\" weight".to_string())]);
    }

    #[test]
    fn a_line_that_is_not_utf8_stops_the_stream_and_is_named() {
        let src: &[u8] = b"time_s,v\n0,\xff\n1,2\n";
        let mut tee = CommentTee::new(src);
        let mut out = Vec::new();
        tee.read_to_end(&mut out).unwrap();
        assert_eq!(out, b"time_s,v\n");
        assert_eq!(tee.not_text, Some(2));
    }
}
