//! MAVLink on the UART: the runtime's stream parser and decoders for what comes in, its
//! MAVLink 2 encoder for what goes out.
//!
//! Only the messages the services use are decoded and encoded. The parser checks frames
//! against [`RX_META`], the requests the services take, and drops every other id; [`decode`]
//! turns a frame into the [`Message`] the services take with that message's own decoder, and
//! [`Link::send`] encodes the nine messages they answer with. `Message::decode` and
//! `v2::encode_dialect` do the same for any message of the services' 26, FTP's and the
//! extended parameters' among them, but their dispatch links every decoder and encoder: the
//! firmware would take 37 848 B of flash with `Message::decode` and 39 552 B with both, 5 080 B
//! and 6 784 B over its 32 768 (see the README).

// MISSION_ITEM, MISSION_REQUEST and MISSION_SET_CURRENT are deprecated in common.xml, but
// ground stations still send them, and the mission server answers them.
#![allow(deprecated)]

use ferrolink_runtime::framing::Feed;
use ferrolink_runtime::mavlink::service::messages::{
    CommandCancel, CommandInt, CommandLong, FileTransferProtocol, Heartbeat, Message,
    MissionClearAll, MissionCount, MissionItem, MissionItemInt, MissionRequest, MissionRequestInt,
    MissionRequestList, MissionSetCurrent, ParamRequestList, ParamRequestRead, ParamSet,
};
use ferrolink_runtime::mavlink::service::Address;
use ferrolink_runtime::mavlink::{
    v2, Dialect, Header, Message as WireMessage, MessageMeta, Parser, PayloadBuf, MAX_PAYLOAD_LEN,
};

use crate::hw::Uart;

/// The messages the services take, sorted by id: the parser drops every other.
pub static RX_META: [MessageMeta; 16] = pick([
    Heartbeat::ID,
    ParamRequestRead::ID,
    ParamRequestList::ID,
    ParamSet::ID,
    MissionItem::ID,
    MissionRequest::ID,
    MissionSetCurrent::ID,
    MissionRequestList::ID,
    MissionCount::ID,
    MissionClearAll::ID,
    MissionRequestInt::ID,
    MissionItemInt::ID,
    CommandInt::ID,
    CommandLong::ID,
    CommandCancel::ID,
    FileTransferProtocol::ID,
]);

/// The entries of the services' message table for `ids` (each must be there), at compile time.
const fn pick<const N: usize>(ids: [u32; N]) -> [MessageMeta; N] {
    let all = <Message as Dialect>::META;
    let mut out = [all[0]; N];
    let mut i = 0;
    while i < N {
        let mut j = 0;
        while all[j].id != ids[i] {
            j += 1;
        }
        out[i] = all[j];
        i += 1;
    }
    out
}

/// The message of id `id` in `payload`, if it is one of [`RX_META`]'s.
pub fn decode(id: u32, p: &[u8]) -> Option<Message> {
    Some(match id {
        Heartbeat::ID => Message::Heartbeat(Heartbeat::decode(p)),
        ParamRequestRead::ID => Message::ParamRequestRead(ParamRequestRead::decode(p)),
        ParamRequestList::ID => Message::ParamRequestList(ParamRequestList::decode(p)),
        ParamSet::ID => Message::ParamSet(ParamSet::decode(p)),
        MissionItem::ID => Message::MissionItem(MissionItem::decode(p)),
        MissionRequest::ID => Message::MissionRequest(MissionRequest::decode(p)),
        MissionSetCurrent::ID => Message::MissionSetCurrent(MissionSetCurrent::decode(p)),
        MissionRequestList::ID => Message::MissionRequestList(MissionRequestList::decode(p)),
        MissionCount::ID => Message::MissionCount(MissionCount::decode(p)),
        MissionClearAll::ID => Message::MissionClearAll(MissionClearAll::decode(p)),
        MissionRequestInt::ID => Message::MissionRequestInt(MissionRequestInt::decode(p)),
        MissionItemInt::ID => Message::MissionItemInt(MissionItemInt::decode(p)),
        CommandInt::ID => Message::CommandInt(CommandInt::decode(p)),
        CommandLong::ID => Message::CommandLong(CommandLong::decode(p)),
        CommandCancel::ID => Message::CommandCancel(CommandCancel::decode(p)),
        FileTransferProtocol::ID => Message::FileTransferProtocol(FileTransferProtocol::decode(p)),
        _ => return None,
    })
}

/// The UART with a parser on its input and a sequence number on its output.
#[derive(Debug)]
pub struct Link {
    uart: Uart,
    parser: &'static mut Parser,
    own: Address,
    /// A received byte the parser has not taken yet (it handed out a frame first).
    held: Option<u8>,
    /// The parser handed out a frame: it may hold another one, so ask it before feeding more.
    again: bool,
    seq: u8,
}

impl Link {
    /// A link on `uart` sending as `own`, with `parser` (made with [`RX_META`]).
    pub fn new(uart: Uart, parser: &'static mut Parser, own: Address) -> Self {
        Self {
            uart,
            parser,
            own,
            held: None,
            again: false,
            seq: 0,
        }
    }

    /// Feeds the parser at most one received byte; a message and its sender when that
    /// completes a frame.
    #[inline(never)]
    pub fn receive(&mut self) -> Option<(Address, Message)> {
        let byte = match self.held.take() {
            Some(byte) => Some(byte),
            None if self.again => None,
            None => Some(self.uart.read()?),
        };
        self.again = false;
        match self.parser.feed(byte.as_slice()) {
            Feed::Consumed => None,
            Feed::Frame { frame, remaining } => {
                self.held = remaining.first().copied();
                self.again = true;
                let h = frame.header();
                let msg = decode(frame.msg_id(), frame.payload())?;
                Some((Address::new(h.sysid, h.compid), msg))
            }
        }
    }

    /// Whether the parser has been given every byte received so far.
    pub fn is_drained(&self) -> bool {
        self.held.is_none() && !self.again
    }

    /// Sends `msg` as a MAVLink 2 frame. Only the messages the services answer with are
    /// encoded (HEARTBEAT, PARAM_VALUE, COMMAND_ACK, the mission protocol's and
    /// FILE_TRANSFER_PROTOCOL); any other is dropped. Each message's own encoder fills the
    /// payload, and one framing serves them all.
    #[inline(never)]
    pub fn send(&mut self, msg: &Message) {
        let mut payload: PayloadBuf = [0; MAX_PAYLOAD_LEN];
        let p = &mut payload;
        let (id, crc_extra, len) = match msg {
            Message::Heartbeat(m) => fill(m, p),
            Message::ParamValue(m) => fill(m, p),
            Message::CommandAck(m) => fill(m, p),
            Message::MissionCount(m) => fill(m, p),
            Message::MissionItemInt(m) => fill(m, p),
            Message::MissionItem(m) => fill(m, p),
            Message::MissionRequestInt(m) => fill(m, p),
            Message::MissionAck(m) => fill(m, p),
            Message::MissionCurrent(m) => fill(m, p),
            Message::FileTransferProtocol(m) => fill(m, p),
            _ => return,
        };
        let header = Header::new(self.seq, self.own.system, self.own.component);
        let mut frame = [0u8; v2::MAX_UNSIGNED_FRAME_LEN];
        let payload = payload.get(..len).unwrap_or_default();
        if let Ok(n) = v2::encode_raw(header, id, crc_extra, payload, &mut frame) {
            self.uart.write(frame.get(..n).unwrap_or_default());
            self.seq = self.seq.wrapping_add(1);
        }
    }
}

/// `m`'s id, CRC_EXTRA and whole payload, written to `p`.
fn fill<M: WireMessage>(m: &M, p: &mut PayloadBuf) -> (u32, u8, usize) {
    (M::ID, M::CRC_EXTRA, m.encode(p))
}
