//! pbrt-v4's scene text as tokens (pbrt's `Tokenizer`): `#` comments to the end of the line,
//! quoted strings with `\` escapes, `[` and `]`, and bare words (directives, numbers, `true` /
//! `false`). Every token keeps its line for messages.

use std::sync::Arc;

use crate::import::diag::Loc;
use crate::scene::SceneError;

/// One token.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Tok {
    /// A bare word: a directive name, a number, `true` / `false`.
    Word(String),
    /// A quoted string (escapes resolved).
    Str(String),
    Open,
    Close,
}

/// A token and its line.
#[derive(Debug, Clone)]
pub(crate) struct Token {
    pub tok: Tok,
    pub line: usize,
}

/// The tokens of one file, read on demand.
pub(crate) struct Tokens {
    text: Vec<u8>,
    pos: usize,
    line: usize,
    pub file: Arc<str>,
    peeked: Option<Token>,
}

impl Tokens {
    pub fn new(text: Vec<u8>, file: Arc<str>) -> Self {
        Tokens {
            text,
            pos: 0,
            line: 1,
            file,
            peeked: None,
        }
    }

    /// A place on `line` of this file.
    pub fn loc(&self, line: usize) -> Loc {
        Loc::new(&self.file, Some(line))
    }

    /// The next token without consuming it.
    pub fn peek(&mut self) -> Result<Option<&Token>, SceneError> {
        if self.peeked.is_none() {
            self.peeked = self.read()?;
        }
        Ok(self.peeked.as_ref())
    }

    /// The next token.
    pub fn next(&mut self) -> Result<Option<Token>, SceneError> {
        match self.peeked.take() {
            Some(t) => Ok(Some(t)),
            None => self.read(),
        }
    }

    fn read(&mut self) -> Result<Option<Token>, SceneError> {
        let t = &self.text;
        // Step 1: whitespace and comments.
        loop {
            while self.pos < t.len() && t[self.pos].is_ascii_whitespace() {
                if t[self.pos] == b'\n' {
                    self.line += 1;
                }
                self.pos += 1;
            }
            if self.pos < t.len() && t[self.pos] == b'#' {
                while self.pos < t.len() && t[self.pos] != b'\n' {
                    self.pos += 1;
                }
                continue;
            }
            break;
        }
        if self.pos >= t.len() {
            return Ok(None);
        }
        let line = self.line;
        let c = t[self.pos];
        // Step 2: the token.
        let tok = match c {
            b'[' => {
                self.pos += 1;
                Tok::Open
            }
            b']' => {
                self.pos += 1;
                Tok::Close
            }
            b'"' => {
                self.pos += 1;
                let mut s = Vec::new();
                loop {
                    let Some(&b) = t.get(self.pos) else {
                        return Err(self.loc(line).error("unterminated string"));
                    };
                    self.pos += 1;
                    match b {
                        b'"' => break,
                        b'\n' => return Err(self.loc(line).error("new line inside a string")),
                        b'\\' => {
                            let e = t.get(self.pos).copied().unwrap_or(b'\\');
                            self.pos += 1;
                            s.push(match e {
                                b'n' => b'\n',
                                b't' => b'\t',
                                other => other,
                            });
                        }
                        other => s.push(other),
                    }
                }
                Tok::Str(
                    String::from_utf8(s)
                        .map_err(|_| self.loc(line).error("string is not UTF-8"))?,
                )
            }
            _ => {
                let start = self.pos;
                while self.pos < t.len()
                    && !t[self.pos].is_ascii_whitespace()
                    && !matches!(t[self.pos], b'[' | b']' | b'"' | b'#')
                {
                    self.pos += 1;
                }
                Tok::Word(String::from_utf8_lossy(&t[start..self.pos]).into_owned())
            }
        };
        Ok(Some(Token { tok, line }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_and_lines() {
        let mut t = Tokens::new(
            b"LookAt 0 0 5 # eye\n  0 0 0\nShape \"trianglemesh\" \"point3 P\" [1 2 -3e-1]\n\"a\\\"b\"".to_vec(),
            Arc::from("a.pbrt"),
        );
        let mut all = Vec::new();
        while let Some(tok) = t.next().unwrap() {
            all.push((tok.tok, tok.line));
        }
        assert_eq!(all[0], (Tok::Word("LookAt".into()), 1));
        assert_eq!(all[4], (Tok::Word("0".into()), 2));
        assert_eq!(all[8], (Tok::Str("trianglemesh".into()), 3));
        assert_eq!(all[10], (Tok::Open, 3));
        assert_eq!(all[13], (Tok::Word("-3e-1".into()), 3));
        assert_eq!(all.last().unwrap().0, Tok::Str("a\"b".into()));
        let mut bad = Tokens::new(b"\n\"open".to_vec(), Arc::from("b.pbrt"));
        assert_eq!(
            bad.next().unwrap_err().to_string(),
            "b.pbrt:2: unterminated string"
        );
    }
}
