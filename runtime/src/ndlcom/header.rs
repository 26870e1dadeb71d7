//! The 4-byte NDLCom header: receiver, sender, counter, payload length, in that order.

/// The header of a frame as it is on the wire (before escaping).
///
/// ```
/// use ferrolink_runtime::ndlcom::Header;
///
/// let header = Header::new(0x81, 1, 7, 16);
/// assert_eq!(header.emit(), [0x81, 1, 7, 16]);
/// assert_eq!(Header::parse(&[0x81, 1, 7, 16, 0xaa]), Some(header));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Header {
    /// Who the frame is for; [`BROADCAST`](super::BROADCAST) for everyone.
    pub receiver: u8,
    /// Who sent it.
    pub sender: u8,
    /// Per (sender, receiver) sequence number, wrapping at 256.
    pub counter: u8,
    /// Payload length, 0..=255.
    pub length: u8,
}

impl Header {
    /// Header length on the wire, before escaping.
    pub const LEN: usize = 4;

    /// A header from its four fields.
    #[inline]
    pub const fn new(receiver: u8, sender: u8, counter: u8, length: u8) -> Self {
        Header {
            receiver,
            sender,
            counter,
            length,
        }
    }

    /// Reads a header from the first four (unescaped) bytes; `None` if there are fewer.
    #[inline]
    pub fn parse(bytes: &[u8]) -> Option<Self> {
        match bytes {
            [receiver, sender, counter, length, ..] => {
                Some(Header::new(*receiver, *sender, *counter, *length))
            }
            _ => None,
        }
    }

    /// The four header bytes in wire order (before escaping).
    #[inline]
    pub const fn emit(&self) -> [u8; 4] {
        [self.receiver, self.sender, self.counter, self.length]
    }

    /// Whether the frame is addressed to everyone.
    #[inline]
    pub const fn is_broadcast(&self) -> bool {
        self.receiver == super::BROADCAST
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_needs_four_bytes() {
        assert_eq!(Header::parse(&[1, 2, 3]), None);
        assert_eq!(Header::parse(&[1, 2, 3, 4]), Some(Header::new(1, 2, 3, 4)));
        assert!(Header::new(0xff, 1, 0, 0).is_broadcast());
    }
}
