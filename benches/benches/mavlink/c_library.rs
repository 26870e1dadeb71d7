//! The MAVLink C library (`c/mavlink_c.c` on headers mavgen generated from the same common.xml),
//! when `build.rs` could build it.

/// The library's `mavlink_heartbeat_t`, `mavlink_attitude_t` and
/// `mavlink_file_transfer_protocol_t` are read back only as bytes; these hold them.
pub type Heartbeat = [u8; 9];
pub type Attitude = [u8; 28];
pub type Ftp = [u8; 254];

// SAFETY: each function reads only the lengths it is given or the fixed sizes its C
// signature names (the `[f32; 6]` and `[u8; 251]` arrays, the out structs above, a frame
// buffer of at least 280 bytes), writes only its out parameter, and keeps no pointer.
unsafe extern "C" {
    pub safe fn c_encode_heartbeat(
        out: &mut [u8; 280],
        seq: u8,
        ty: u8,
        autopilot: u8,
        base_mode: u8,
        custom_mode: u32,
        system_status: u8,
    ) -> usize;
    pub safe fn c_encode_attitude(
        out: &mut [u8; 280],
        seq: u8,
        time_boot_ms: u32,
        v: &[f32; 6],
    ) -> usize;
    pub safe fn c_encode_ftp(
        out: &mut [u8; 280],
        seq: u8,
        target_network: u8,
        target_system: u8,
        target_component: u8,
        payload: &[u8; 251],
    ) -> usize;
    fn c_decode_heartbeat(frame: *const u8, len: usize, out: &mut Heartbeat) -> i32;
    fn c_decode_attitude(frame: *const u8, len: usize, out: &mut Attitude) -> i32;
    fn c_decode_ftp(frame: *const u8, len: usize, out: &mut Ftp) -> i32;
    fn c_checksum(body: *const u8, len: usize, crc_extra: u8) -> u16;
    fn c_stream(bytes: *const u8, len: usize, sink: extern "C" fn(*const u8)) -> usize;
}

pub use self::{
    c_encode_attitude as encode_attitude, c_encode_ftp as encode_ftp,
    c_encode_heartbeat as encode_heartbeat,
};

pub fn decode_heartbeat(frame: &[u8], out: &mut Heartbeat) -> i32 {
    // SAFETY: `frame` is valid for `frame.len()` bytes.
    unsafe { c_decode_heartbeat(frame.as_ptr(), frame.len(), out) }
}

pub fn decode_attitude(frame: &[u8], out: &mut Attitude) -> i32 {
    // SAFETY: as above.
    unsafe { c_decode_attitude(frame.as_ptr(), frame.len(), out) }
}

pub fn decode_ftp(frame: &[u8], out: &mut Ftp) -> i32 {
    // SAFETY: as above.
    unsafe { c_decode_ftp(frame.as_ptr(), frame.len(), out) }
}

pub fn checksum(body: &[u8], crc_extra: u8) -> u16 {
    // SAFETY: as above.
    unsafe { c_checksum(body.as_ptr(), body.len(), crc_extra) }
}

extern "C" fn sink(decoded: *const u8) {
    std::hint::black_box(decoded);
}

/// Parses and decodes every message of `bytes`; returns how many.
pub fn stream(bytes: &[u8]) -> usize {
    // SAFETY: as above; `sink` keeps nothing.
    unsafe { c_stream(bytes.as_ptr(), bytes.len(), sink) }
}
