//! The two ways a PLY body is read: ASCII (one entry per line, errors at a line number) and
//! binary, little- or big-endian (errors at a byte offset; running out of bytes means the file is
//! truncated). Every read is bounds-checked; nothing here allocates per declared count.

use super::mesh::FileError;
use super::ply::Scalar;

/// A stream of typed values, entry by entry.
pub(crate) trait Source {
    /// Starts entry `index` of element `name`, which has `props` properties; `fixed` when it has
    /// no lists (so an ASCII line must hold exactly `props` values).
    fn begin(&mut self, name: &str, index: u64, props: usize, fixed: bool)
        -> Result<(), FileError>;
    /// Reads one value of type `s` for property `prop`.
    fn scalar(&mut self, s: Scalar, prop: &str) -> Result<f64, FileError>;
    /// Skips `n` values of type `s`.
    fn skip(&mut self, s: Scalar, n: u64, prop: &str) -> Result<(), FileError>;
    /// Fails unless `n` values of type `s` can still be read.
    fn check_room(&mut self, s: Scalar, n: u64, prop: &str) -> Result<(), FileError>;
    /// Ends the entry (ASCII: nothing may be left on the line).
    fn end(&mut self) -> Result<(), FileError>;
    /// An error at the current position.
    fn error(&self, msg: &str) -> FileError;
}

/// ASCII body: entries are lines of whitespace-separated values.
pub(crate) struct Ascii<'a> {
    rest: &'a [u8],
    /// Number of the line being read.
    line: usize,
    /// Number the next line will have.
    next_line: usize,
    tokens: std::str::SplitAsciiWhitespace<'a>,
}

impl<'a> Ascii<'a> {
    pub(crate) fn new(body: &'a [u8], first_line: usize) -> Self {
        Ascii {
            rest: body,
            line: first_line,
            next_line: first_line,
            tokens: "".split_ascii_whitespace(),
        }
    }
}

/// The inclusive range of an integer type.
fn int_range(s: Scalar) -> (i64, i64) {
    match s {
        Scalar::I8 => (i8::MIN as i64, i8::MAX as i64),
        Scalar::U8 => (0, u8::MAX as i64),
        Scalar::I16 => (i16::MIN as i64, i16::MAX as i64),
        Scalar::U16 => (0, u16::MAX as i64),
        Scalar::I32 => (i32::MIN as i64, i32::MAX as i64),
        _ => (0, u32::MAX as i64),
    }
}

impl Source for Ascii<'_> {
    fn begin(
        &mut self,
        name: &str,
        index: u64,
        props: usize,
        fixed: bool,
    ) -> Result<(), FileError> {
        // Skip blank lines; an entry is the next non-blank one.
        loop {
            if self.rest.is_empty() {
                return Err(FileError::at(
                    self.next_line,
                    format!("unexpected end of file: {name} {index} is missing"),
                ));
            }
            let end = self
                .rest
                .iter()
                .position(|&b| b == b'\n')
                .unwrap_or(self.rest.len());
            let raw = &self.rest[..end];
            self.rest = self.rest.get(end + 1..).unwrap_or(&[]);
            self.line = self.next_line;
            self.next_line += 1;
            let Ok(text) = std::str::from_utf8(raw) else {
                return Err(FileError::at(self.line, "the line is not text"));
            };
            if text.trim().is_empty() {
                continue;
            }
            self.tokens = text.split_ascii_whitespace();
            break;
        }
        if fixed {
            let count = self.tokens.clone().count();
            if count != props {
                return Err(FileError::at(
                    self.line,
                    format!("expected {props} numbers ({name} {index}), got {count}"),
                ));
            }
        }
        Ok(())
    }

    fn scalar(&mut self, s: Scalar, prop: &str) -> Result<f64, FileError> {
        let Some(token) = self.tokens.next() else {
            return Err(FileError::at(
                self.line,
                format!("the line ends early: no value for \"{prop}\""),
            ));
        };
        if s.is_integer() {
            let (lo, hi) = int_range(s);
            match token.parse::<i64>() {
                Ok(v) if v >= lo && v <= hi => Ok(v as f64),
                _ => Err(FileError::at(
                    self.line,
                    format!("expected an integer in [{lo}, {hi}] for \"{prop}\", got \"{token}\""),
                )),
            }
        } else {
            token.parse::<f64>().map_err(|_| {
                FileError::at(
                    self.line,
                    format!("expected a number for \"{prop}\", got \"{token}\""),
                )
            })
        }
    }

    fn skip(&mut self, s: Scalar, n: u64, prop: &str) -> Result<(), FileError> {
        for _ in 0..n {
            self.scalar(s, prop)?;
        }
        Ok(())
    }

    fn check_room(&mut self, _s: Scalar, n: u64, prop: &str) -> Result<(), FileError> {
        let left = self.tokens.clone().count() as u64;
        if left < n {
            return Err(FileError::at(
                self.line,
                format!("the line ends early: \"{prop}\" has {n} values but only {left} follow"),
            ));
        }
        Ok(())
    }

    fn end(&mut self) -> Result<(), FileError> {
        if let Some(extra) = self.tokens.next() {
            return Err(FileError::at(
                self.line,
                format!("unexpected extra value \"{extra}\" at the end of the line"),
            ));
        }
        Ok(())
    }

    fn error(&self, msg: &str) -> FileError {
        FileError::at(self.line, msg)
    }
}

/// Binary body, little- or big-endian.
pub(crate) struct Binary<'a> {
    data: &'a [u8],
    pos: usize,
    /// File offset of `data[0]`, for messages.
    offset: usize,
    big: bool,
    element: String,
    index: u64,
}

impl<'a> Binary<'a> {
    pub(crate) fn new(body: &'a [u8], offset: usize, big: bool) -> Self {
        Binary {
            data: body,
            pos: 0,
            offset,
            big,
            element: String::new(),
            index: 0,
        }
    }

    fn truncated(&self) -> FileError {
        self.error(&format!(
            "unexpected end of file in {} {} (the file is truncated)",
            self.element, self.index
        ))
    }

    fn room(&self, s: Scalar, n: u64) -> bool {
        let left = (self.data.len() - self.pos) as u128;
        n as u128 * s.size() as u128 <= left
    }
}

/// Decodes one binary value.
fn decode(bytes: &[u8], s: Scalar, big: bool) -> f64 {
    macro_rules! num {
        ($t:ty, $n:expr) => {{
            let mut a = [0u8; $n];
            a.copy_from_slice(&bytes[..$n]);
            if big {
                <$t>::from_be_bytes(a) as f64
            } else {
                <$t>::from_le_bytes(a) as f64
            }
        }};
    }
    match s {
        Scalar::I8 => num!(i8, 1),
        Scalar::U8 => num!(u8, 1),
        Scalar::I16 => num!(i16, 2),
        Scalar::U16 => num!(u16, 2),
        Scalar::I32 => num!(i32, 4),
        Scalar::U32 => num!(u32, 4),
        Scalar::F32 => num!(f32, 4),
        Scalar::F64 => num!(f64, 8),
    }
}

impl Source for Binary<'_> {
    fn begin(
        &mut self,
        name: &str,
        index: u64,
        _props: usize,
        _fixed: bool,
    ) -> Result<(), FileError> {
        if self.element != name {
            self.element = name.to_string();
        }
        self.index = index;
        Ok(())
    }

    fn scalar(&mut self, s: Scalar, _prop: &str) -> Result<f64, FileError> {
        let size = s.size();
        let Some(bytes) = self.data.get(self.pos..self.pos + size) else {
            return Err(self.truncated());
        };
        self.pos += size;
        Ok(decode(bytes, s, self.big))
    }

    fn skip(&mut self, s: Scalar, n: u64, _prop: &str) -> Result<(), FileError> {
        if !self.room(s, n) {
            return Err(self.truncated());
        }
        self.pos += n as usize * s.size();
        Ok(())
    }

    fn check_room(&mut self, s: Scalar, n: u64, _prop: &str) -> Result<(), FileError> {
        if self.room(s, n) {
            Ok(())
        } else {
            Err(self.truncated())
        }
    }

    fn end(&mut self) -> Result<(), FileError> {
        Ok(())
    }

    fn error(&self, msg: &str) -> FileError {
        FileError {
            line: None,
            msg: format!("byte {}: {msg}", self.offset + self.pos),
        }
    }
}
