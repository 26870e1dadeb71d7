//! Conversions between ModRob-1 messages and any `embedded_can::Frame` (feature
//! `embedded-can`).
//!
//! CAN-1 uses 29-bit extended identifiers only: a frame with a standard identifier, or a remote
//! frame, is a [`DecodeError`].

use embedded_can::{ExtendedId, Frame, Id};

use super::message::{DecodeError, Message};

/// The message as a CAN data frame with an extended identifier; `None` only if the frame type
/// refuses it.
pub fn to_frame<F: Frame>(message: &Message) -> Option<F> {
    let can = message.to_can();
    F::new(ExtendedId::new(can.id)?, can.data())
}

/// Decodes a CAN data frame with an extended identifier.
pub fn from_frame<F: Frame>(frame: &F) -> Result<Message, DecodeError> {
    if frame.is_remote_frame() {
        return Err(DecodeError::RemoteFrame);
    }
    match frame.id() {
        Id::Extended(id) => Message::from_can(id.as_raw(), frame.data()),
        Id::Standard(_) => Err(DecodeError::StandardId),
    }
}
