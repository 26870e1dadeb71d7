//! ModRob-1: byte vectors written from the specification (CAN-1, UART.B-1, Ethernet-1),
//! reserved values, property round trips, the stream parser at every chunk size, batching.

use ferrolink_runtime::modrob::ethernet::{
    Header, Packet, PacketBuilder, PacketError, HEADER_LEN, MAX_DATAGRAM_LEN,
};
use ferrolink_runtime::modrob::parser::{Parser, Stats};
use ferrolink_runtime::modrob::uart::{self, Crc8, FrameError};
use ferrolink_runtime::modrob::{CommandKind, DecodeError, Message};
use proptest::prelude::*;

#[path = "scripts/modrob.rs"]
mod scripts;

fn hex(s: &str) -> Vec<u8> {
    hex::decode(s.replace(' ', "")).expect("valid hex")
}

/// CRC-8/SMBUS bit by bit (poly 0x07, init 0, not reflected, no final xor), independent of the
/// `crc` crate.
fn crc8_smbus(bytes: &[u8]) -> u8 {
    let mut crc = 0u8;
    for &b in bytes {
        crc ^= b;
        for _ in 0..8 {
            crc = if crc & 0x80 != 0 {
                crc << 1 ^ 0x07
            } else {
                crc << 1
            };
        }
    }
    crc
}

/// (message, CAN-1 identifier, CAN-1 data, UART.B-1 frame), all written from the spec's
/// tables: identifier = type << 24 | MI << 8 | VI, `id_and_len` = identifier << 4 | length,
/// little-endian, then the data and the CRC-8/SMBUS of everything before it.
fn vectors() -> Vec<(Message, u32, Vec<u8>, Vec<u8>)> {
    vec![
        (
            // set value 1.5 (0x3fc00000) on MI 0x0102, VI 3
            Message::Command {
                module: 0x0102,
                variable: 3,
                command: CommandKind::SetValue(1.5),
            },
            0x0001_0203,
            hex("0000c03f 00 00"),
            hex("5a 36201000 0000c03f0000 14"),
        ),
        (
            // set publication frequency 100 Hz (0x42c80000) on MI 0x0102, VI 255
            Message::Command {
                module: 0x0102,
                variable: 255,
                command: CommandKind::SetFrequency(100.0),
            },
            0x0001_02ff,
            hex("0000c842 01 00"),
            hex("5a f62f1000 0000c8420100 24"),
        ),
        (
            // subscribe MI 0xbeef VI 0 to MI 0x1234 VI 0x56
            Message::Command {
                module: 0xbeef,
                variable: 0,
                command: CommandKind::SetSubscription {
                    module: 0x1234,
                    variable: 0x56,
                },
            },
            0x00be_ef00,
            hex("00 3412 56 02 00"),
            hex("5a 06f0ee0b 003412560200 a7"),
        ),
        (
            // publication -2.0 (0xc0000000) from MI 0xffff, VI 0x80
            Message::Publication {
                module: 0xffff,
                variable: 0x80,
                value: -2.0,
            },
            0x01ff_ff80,
            hex("000000c0 0000"),
            hex("5a 06f8ff1f 000000c00000 88"),
        ),
        (
            // chunk 2 of 3 from MI 1: "hello", zero-padded to 7 bytes
            Message::Piecewise {
                module: 1,
                chunk: 2,
                chunks: 3,
                data: *b"hello\0\0",
            },
            0x0200_0102,
            hex("68656c6c6f0000 03"),
            hex("5a 28100020 68656c6c6f000003 ec"),
        ),
    ]
}

#[test]
fn independent_crc_matches_the_catalogue() {
    assert_eq!(crc8_smbus(b"123456789"), 0xF4);
    assert_eq!(Crc8::SMBUS.checksum(b"123456789"), 0xF4);
    for (_, _, _, frame) in vectors() {
        let (body, crc) = frame.split_at(frame.len() - 1);
        assert_eq!(crc8_smbus(body), crc[0]);
    }
}

#[test]
fn can_vectors() {
    for (message, id, data, _) in vectors() {
        let can = message.to_can();
        assert_eq!(format!("{:08x}", can.id), format!("{id:08x}"));
        assert_eq!(can.data(), &data[..], "{message:?}");
        assert_eq!(Message::from_can(id, &data), Ok(message));
    }
}

#[test]
fn uart_vectors() {
    for (message, _, _, frame) in vectors() {
        let mut buf = [0xa5u8; 20];
        let n = uart::encode(&message, &mut buf).unwrap();
        assert_eq!(&buf[..n], &frame[..], "{message:?}");
        assert_eq!(buf[n..], [0xa5; 20][n..]);
        assert_eq!(uart::decode(&frame), Ok(message));
        assert_eq!(n, if frame.len() == 14 { 14 } else { 12 });
    }
}

#[test]
fn can_reserved_values_and_lengths_are_errors() {
    let cases: [(u32, &str, DecodeError); 9] = [
        (0x0300_0000, "000000000000", DecodeError::ReservedType),
        (0x03ff_ffff, "0000000000000000", DecodeError::ReservedType),
        (
            0x0000_0000,
            "000000000300",
            DecodeError::ReservedCommand { command: 3 },
        ),
        (
            0x0000_0000,
            "00000000ff00",
            DecodeError::ReservedCommand { command: 255 },
        ),
        (
            0x0400_0000,
            "000000000000",
            DecodeError::ReservedIdBits { id: 0x0400_0000 },
        ),
        (
            0x1000_0000,
            "000000000000",
            DecodeError::ReservedIdBits { id: 0x1000_0000 },
        ),
        (
            0x0100_0000,
            "0000000000000000",
            DecodeError::DataLength {
                expected: 6,
                got: 8,
            },
        ),
        (
            0x0200_0000,
            "000000000000",
            DecodeError::DataLength {
                expected: 8,
                got: 6,
            },
        ),
        (
            0x0000_0000,
            "",
            DecodeError::DataLength {
                expected: 6,
                got: 0,
            },
        ),
    ];
    for (id, data, error) in cases {
        assert_eq!(
            Message::from_can(id, &hex(data)),
            Err(error),
            "{id:08x} {data}"
        );
    }
    // Reserved bytes and byte 0 of a subscription are not interpreted.
    assert_eq!(
        Message::from_can(0x0000_0001, &hex("ff3412560277")),
        Ok(Message::Command {
            module: 0,
            variable: 1,
            command: CommandKind::SetSubscription {
                module: 0x1234,
                variable: 0x56
            }
        })
    );
}

#[test]
fn uart_reserved_values_and_lengths_are_errors() {
    let cases = [
        // type 11, valid CRC
        (
            "5a 06000030 000000000000 e1",
            FrameError::Decode(DecodeError::ReservedType),
        ),
        // command type 3, valid CRC
        (
            "5a 06000000 000000000300 ac",
            FrameError::Decode(DecodeError::ReservedCommand { command: 3 }),
        ),
        // identifier bit 26 set
        (
            "5a 06000040 000000000000 d6",
            FrameError::Decode(DecodeError::ReservedIdBits { id: 0x0400_0000 }),
        ),
        // a publication with length 8, valid CRC
        (
            "5a 08000010 0000000000000000 74",
            FrameError::Decode(DecodeError::DataLength {
                expected: 6,
                got: 8,
            }),
        ),
        (
            "5a 07000010 00000000000000 00",
            FrameError::BadLength { len: 7 },
        ),
        (
            "a5 06000010 000000000000 00",
            FrameError::BadSync { byte: 0xa5 },
        ),
        (
            "5a 36201000 0000c03f0000 15",
            FrameError::Crc {
                computed: 0x14,
                received: 0x15,
            },
        ),
        (
            "5a 28100020 68656c6c6f0000",
            FrameError::Truncated {
                needed: 14,
                available: 12,
            },
        ),
    ];
    for (frame, error) in cases {
        assert_eq!(uart::decode(&hex(frame)), Err(error), "{frame}");
    }
}

#[test]
fn every_variable_id_round_trips() {
    for vi in 0..=255u8 {
        let messages = [
            Message::Command {
                module: 0x8001,
                variable: vi,
                command: CommandKind::SetValue(f32::from(vi)),
            },
            Message::Publication {
                module: 0x8001,
                variable: vi,
                value: -f32::from(vi),
            },
            Message::Piecewise {
                module: 0x8001,
                chunk: vi,
                chunks: 255,
                data: [vi; 7],
            },
        ];
        for m in messages {
            let can = m.to_can();
            assert_eq!(can.id & 0xff, u32::from(vi));
            assert_eq!(Message::from_can(can.id, can.data()), Ok(m));
            let mut buf = [0u8; uart::MAX_FRAME_LEN];
            let n = uart::encode(&m, &mut buf).unwrap();
            assert_eq!(uart::decode(&buf[..n]), Ok(m));
        }
    }
}

fn message() -> impl Strategy<Value = Message> {
    let value = any::<u32>().prop_map(f32::from_bits);
    let command = prop_oneof![
        value.clone().prop_map(CommandKind::SetValue),
        value.clone().prop_map(CommandKind::SetFrequency),
        (any::<u16>(), any::<u8>())
            .prop_map(|(module, variable)| CommandKind::SetSubscription { module, variable }),
    ];
    prop_oneof![
        (any::<u16>(), any::<u8>(), command).prop_map(|(module, variable, command)| {
            Message::Command {
                module,
                variable,
                command,
            }
        }),
        (any::<u16>(), any::<u8>(), value).prop_map(|(module, variable, value)| {
            Message::Publication {
                module,
                variable,
                value,
            }
        }),
        (any::<u16>(), any::<u8>(), any::<u8>(), any::<[u8; 7]>()).prop_map(
            |(module, chunk, chunks, data)| Message::Piecewise {
                module,
                chunk,
                chunks,
                data
            }
        ),
    ]
}

proptest! {
    #[test]
    fn can_round_trip(m in message()) {
        let can = m.to_can();
        prop_assert!(can.id <= 0x03ff_ffff);
        let back = Message::from_can(can.id, can.data()).unwrap();
        prop_assert!(back.same_wire(&m));
    }

    #[test]
    fn uart_round_trip(m in message()) {
        let mut buf = [0u8; uart::MAX_FRAME_LEN];
        let n = uart::encode(&m, &mut buf).unwrap();
        prop_assert_eq!(n, uart::encoded_len(&m));
        prop_assert_eq!(crc8_smbus(&buf[..n - 1]), buf[n - 1]);
        prop_assert!(uart::decode(&buf[..n]).unwrap().same_wire(&m));
        let (messages, stats) = scripts::decode(&buf[..n], &mut [n].into_iter());
        prop_assert_eq!(messages.len(), 1);
        prop_assert!(messages[0].same_wire(&m));
        prop_assert_eq!(stats.dropped, 0);
    }

    #[test]
    fn parser_invariants(data in proptest::collection::vec(any::<u8>(), 0..200)) {
        scripts::check_parser(&data);
    }

    #[test]
    fn parser_invariants_on_frames_and_noise(
        parts in proptest::collection::vec((message(), proptest::collection::vec(any::<u8>(), 0..6)), 0..12),
        seed in any::<u8>(),
    ) {
        let mut data = vec![seed];
        for (m, noise) in &parts {
            data.extend_from_slice(noise);
            let mut buf = [0u8; uart::MAX_FRAME_LEN];
            let n = uart::encode(m, &mut buf).unwrap();
            data.extend_from_slice(&buf[..n]);
        }
        scripts::check_parser(&data);
        scripts::check_packet(&data);
    }

    #[test]
    fn packet_round_trip(messages in proptest::collection::vec(message(), 0..130)) {
        let mut buf = [0u8; MAX_DATAGRAM_LEN];
        let mut builder = PacketBuilder::new(&mut buf, [7; 16], [9; 16]).unwrap();
        let mut taken = 0;
        for m in &messages {
            if builder.push(m).is_err() {
                break;
            }
            taken += 1;
        }
        let packet = Packet::new_checked(builder.finish()).unwrap();
        prop_assert_eq!(usize::from(packet.count()), taken);
        let back: Vec<Message> = packet.messages().map(|m| m.unwrap()).collect();
        prop_assert_eq!(back.len(), taken);
        for (a, b) in back.iter().zip(&messages) {
            prop_assert!(a.same_wire(b));
        }
    }

    #[test]
    fn packet_reader_never_panics(data in proptest::collection::vec(any::<u8>(), 0..120)) {
        scripts::check_packet(&data);
    }
}

/// Garbage, a bad length nibble, false candidates with a real frame inside them, a valid CRC
/// on a reserved type, a broken CRC, and an unfinished frame at the end.
fn noisy_stream() -> (Vec<u8>, Vec<Message>) {
    let v = vectors();
    let frame = |i: usize| v[i].3.clone();
    let stream = [
        hex("00ff13"),                   // 3 dropped
        hex("5a07000000"),               // bad length nibble: 5 dropped
        frame(0),                        // set value
        hex("5a36201000"),               // claims 12 bytes, CRC fails: 5 dropped
        frame(4),                        // piecewise, starting inside that candidate
        hex("5a3800000000"),             // claims 14 bytes, CRC fails: 6 dropped
        frame(1),                        // set frequency, inside that candidate
        hex("5a06000030000000000000e1"), // type 11, valid CRC: 12 dropped
        hex("5a362010000000c03f000015"), // CRC off by one: 12 dropped
        frame(2),                        // set subscription
        hex("5a3620"),                   // unfinished: 3 pending
    ]
    .concat();
    let messages = vec![v[0].0, v[4].0, v[1].0, v[2].0];
    (stream, messages)
}

#[test]
fn stream_at_every_chunk_size() {
    let (stream, expected) = noisy_stream();
    assert_eq!(stream.len(), 96);
    for chunk in 1..=stream.len() {
        let mut parser = Parser::new();
        let mut got = Vec::new();
        for piece in stream.chunks(chunk) {
            parser.feed_all(piece, |m| got.push(m));
        }
        assert_eq!(got, expected, "chunk size {chunk}");
        assert_eq!(parser.pending(), 3);
        parser.finish();
        assert_eq!(
            *parser.stats(),
            Stats {
                frames: 4,
                bytes: 96,
                crc_failures: 3,
                bad_length: 1,
                decode_errors: 1,
                dropped: 46,
            },
            "chunk size {chunk}"
        );
    }
}

#[test]
fn feed_returns_the_rest_of_the_input() {
    let (stream, expected) = noisy_stream();
    let mut parser = Parser::new();
    let mut input = &stream[..];
    let mut got = Vec::new();
    while let ferrolink_runtime::modrob::Feed::Frame {
        frame: message,
        remaining,
    } = parser.feed(input)
    {
        assert!(remaining.len() < input.len());
        got.push(message);
        input = remaining;
    }
    assert_eq!(got, expected);
}

#[test]
fn another_crc_is_used_throughout() {
    static AUTOSAR: Crc8 = Crc8::new(&crc::CRC_8_AUTOSAR);
    let m = vectors()[3].0;
    let mut buf = [0u8; 16];
    let n = uart::encode_with(&m, &AUTOSAR, &mut buf).unwrap();
    assert_eq!(buf[n - 1], AUTOSAR.checksum(&buf[..n - 1]));
    assert!(matches!(
        uart::decode(&buf[..n]),
        Err(FrameError::Crc { .. })
    ));
    assert_eq!(uart::decode_with(&buf[..n], &AUTOSAR), Ok(m));
    let mut parser = Parser::with_crc(&AUTOSAR);
    let mut got = Vec::new();
    parser.feed_all(&buf[..n], |m| got.push(m));
    assert_eq!(got, vec![m]);
}

/// Header: message id 00..0f, module id 10..1f, count 2 little-endian; then the set value and
/// the publication frames of the vectors.
const PACKET: &str = "000102030405060708090a0b0c0d0e0f 101112131415161718191a1b1c1d1e1f 0200
                      5a362010000000c03f000014 5a06f8ff1f000000c0000088";

#[test]
fn ethernet_vector() {
    let packet_bytes = hex(&PACKET.replace(['\n', ' '], ""));
    let message_id: [u8; 16] = core::array::from_fn(|i| i as u8);
    let module_id: [u8; 16] = core::array::from_fn(|i| 0x10 + i as u8);
    let v = vectors();
    let mut buf = [0xa5u8; 100];
    let mut builder = PacketBuilder::new(&mut buf, message_id, module_id).unwrap();
    builder.push(&v[0].0).unwrap();
    builder.push(&v[3].0).unwrap();
    assert_eq!(builder.count(), 2);
    assert_eq!(builder.finish(), &packet_bytes[..]);

    let packet = Packet::new_checked(&packet_bytes).unwrap();
    assert_eq!(
        *packet.header(),
        Header {
            message_id,
            module_id,
            count: 2
        }
    );
    let got: Vec<_> = packet.messages().collect();
    assert_eq!(got, vec![Ok(v[0].0), Ok(v[3].0)]);
}

#[test]
fn ethernet_errors() {
    let bytes = hex(&PACKET.replace(['\n', ' '], ""));
    for cut in 0..bytes.len() {
        let err = Packet::new_checked(&bytes[..cut]).unwrap_err();
        match cut {
            0..HEADER_LEN => assert_eq!(err, PacketError::TooShort { len: cut }),
            34..46 => assert_eq!(err, PacketError::Truncated { index: 0 }),
            _ => assert_eq!(err, PacketError::Truncated { index: 1 }),
        }
    }
    let mut long = bytes.clone();
    long.push(0);
    assert_eq!(
        Packet::new_checked(&long).unwrap_err(),
        PacketError::TrailingBytes { len: 1 }
    );
    let mut bad = bytes.clone();
    bad[34 + 12] = 0x5b;
    assert_eq!(
        Packet::new_checked(&bad).unwrap_err(),
        PacketError::BadMessage {
            index: 1,
            error: FrameError::BadSync { byte: 0x5b }
        }
    );
    let mut crc = bytes.clone();
    *crc.last_mut().unwrap() ^= 0xff;
    let packet = Packet::new_checked(&crc).unwrap();
    let got: Vec<_> = packet.messages().collect();
    assert!(got[0].is_ok());
    assert!(matches!(got[1], Err(FrameError::Crc { .. })));
}

#[test]
fn batching_fills_a_datagram() {
    let publication = |i: u8| Message::Publication {
        module: 1,
        variable: i,
        value: f32::from(i),
    };
    // The paper's example: 35 publications are 420 bytes of messages, one datagram.
    let mut buf = [0u8; 2000];
    let mut builder = PacketBuilder::new(&mut buf, [0; 16], [0; 16]).unwrap();
    for i in 0..35 {
        builder.push(&publication(i)).unwrap();
    }
    assert_eq!(builder.len(), HEADER_LEN + 420);
    // Up to 1472 bytes: (1472 - 34) / 12 = 119 publications, 1462 bytes.
    for i in 35..119 {
        builder.push(&publication(i)).unwrap();
    }
    assert_eq!(builder.len(), 1462);
    assert_eq!(builder.remaining(), 10);
    assert_eq!(builder.push(&publication(119)), Err(publication(119)));
    assert_eq!(builder.count(), 119);
    let packet = Packet::new_checked(builder.finish()).unwrap();
    assert_eq!(packet.count(), 119);
    assert!(packet
        .messages()
        .enumerate()
        .all(|(i, m)| m == Ok(publication(i as u8))));

    // A smaller datagram, and a buffer below the header.
    let mut buf = [0u8; 100];
    let mut builder = PacketBuilder::new(&mut buf, [0; 16], [0; 16]).unwrap();
    builder.set_max_len(HEADER_LEN + 26);
    builder.push(&publication(0)).unwrap();
    builder.push(&publication(1)).unwrap();
    let piece = vectors()[4].0;
    assert_eq!(builder.push(&piece), Err(piece));
    assert_eq!(
        PacketBuilder::new(&mut [0u8; 33], [0; 16], [0; 16]).unwrap_err(),
        PacketError::BufferTooSmall { available: 33 }
    );
}

#[cfg(feature = "embedded-can")]
mod embedded_can_frames {
    use super::*;
    use embedded_can::{ExtendedId, Frame, Id, StandardId};
    use ferrolink_runtime::modrob::can::{from_frame, to_frame};

    #[derive(Debug, Clone, PartialEq)]
    struct TestFrame {
        id: Id,
        data: Vec<u8>,
        remote: bool,
    }

    impl Frame for TestFrame {
        fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
            (data.len() <= 8).then(|| TestFrame {
                id: id.into(),
                data: data.to_vec(),
                remote: false,
            })
        }
        fn new_remote(id: impl Into<Id>, dlc: usize) -> Option<Self> {
            (dlc <= 8).then(|| TestFrame {
                id: id.into(),
                data: vec![0; dlc],
                remote: true,
            })
        }
        fn is_extended(&self) -> bool {
            matches!(self.id, Id::Extended(_))
        }
        fn is_remote_frame(&self) -> bool {
            self.remote
        }
        fn id(&self) -> Id {
            self.id
        }
        fn dlc(&self) -> usize {
            self.data.len()
        }
        fn data(&self) -> &[u8] {
            &self.data
        }
    }

    #[test]
    fn frames_round_trip_and_standard_ids_are_errors() {
        for (message, id, data, _) in vectors() {
            let frame: TestFrame = to_frame(&message).unwrap();
            assert_eq!(frame.id, Id::Extended(ExtendedId::new(id).unwrap()));
            assert_eq!(frame.data, data);
            assert_eq!(from_frame(&frame), Ok(message));
        }
        let standard = TestFrame::new(StandardId::new(0x123).unwrap(), &[0; 6]).unwrap();
        assert_eq!(from_frame(&standard), Err(DecodeError::StandardId));
        let remote = TestFrame::new_remote(ExtendedId::new(0x0100_0000).unwrap(), 6).unwrap();
        assert_eq!(from_frame(&remote), Err(DecodeError::RemoteFrame));
    }
}
