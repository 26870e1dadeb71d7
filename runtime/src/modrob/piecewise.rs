//! Piecewise transmission: a byte array (a module's info text) in numbered 7-byte chunks.
//!
//! CAN-1 does not carry the array's length, and the last chunk is padded with zeros, so the
//! length is the chunks' bytes without the trailing zeros. Info texts therefore hold no NUL
//! byte (the generator checks), and an array is at most 255 chunks (1785 bytes).

use super::message::{Message, CHUNK_LEN};

/// The longest array that fits 255 chunks.
pub const MAX_LEN: usize = CHUNK_LEN * u8::MAX as usize;

/// How many chunks `len` bytes take (at least one: an empty array is one zero chunk).
pub const fn chunk_count(len: usize) -> usize {
    if len == 0 {
        1
    } else {
        len.div_ceil(CHUNK_LEN)
    }
}

/// Cuts one array into chunk messages, one per call to [`Sender::next`].
#[derive(Debug, Clone)]
pub struct Sender<'a> {
    module: u16,
    data: &'a [u8],
    next: usize,
    chunks: usize,
}

impl<'a> Sender<'a> {
    /// A sender of `data` from module `module`; `data` is cut at [`MAX_LEN`] bytes. It starts
    /// finished: call [`Sender::restart`] to send.
    pub fn new(module: u16, data: &'a [u8]) -> Self {
        let data = &data[..data.len().min(MAX_LEN)];
        let chunks = chunk_count(data.len());
        Self {
            module,
            data,
            next: chunks,
            chunks,
        }
    }

    /// Changes the sending module's MI (for chunks not sent yet).
    pub fn set_module(&mut self, module: u16) {
        self.module = module;
    }

    /// Sends the array again from chunk 0.
    pub fn restart(&mut self) {
        self.next = 0;
    }

    /// Whether every chunk has been handed out.
    pub fn is_done(&self) -> bool {
        self.next >= self.chunks
    }

    /// The number of chunks of the array.
    pub fn chunks(&self) -> u8 {
        self.chunks as u8
    }

    /// The next chunk, or `None` once the last one was handed out.
    pub fn next_chunk(&mut self) -> Option<Message> {
        if self.is_done() {
            return None;
        }
        let start = self.next * CHUNK_LEN;
        let part = self.data.get(start..).unwrap_or(&[]);
        let part = &part[..part.len().min(CHUNK_LEN)];
        let mut data = [0u8; CHUNK_LEN];
        data[..part.len()].copy_from_slice(part);
        let chunk = self.next as u8;
        self.next += 1;
        Some(Message::Piecewise {
            module: self.module,
            chunk,
            chunks: self.chunks as u8,
            data,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_and_pads() {
        let mut s = Sender::new(9, b"0123456789");
        assert!(s.is_done());
        s.restart();
        let a = s.next_chunk().unwrap();
        let b = s.next_chunk().unwrap();
        assert_eq!(s.next_chunk(), None);
        assert_eq!(
            a,
            Message::Piecewise {
                module: 9,
                chunk: 0,
                chunks: 2,
                data: *b"0123456"
            }
        );
        assert_eq!(
            b,
            Message::Piecewise {
                module: 9,
                chunk: 1,
                chunks: 2,
                data: *b"789\0\0\0\0"
            }
        );
    }

    #[test]
    fn empty_and_longest() {
        let mut s = Sender::new(1, b"");
        s.restart();
        assert_eq!(s.chunks(), 1);
        assert!(s.next_chunk().is_some() && s.next_chunk().is_none());
        let long = [b'x'; MAX_LEN + 10];
        let mut s = Sender::new(1, &long);
        s.restart();
        assert_eq!(s.chunks(), 255);
        assert_eq!((0..300).filter_map(|_| s.next_chunk()).count(), 255);
    }
}
