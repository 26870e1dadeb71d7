//! ModRob-1 module engine: limits, input and output semantics, a subscription chain across
//! three modules, rate changes, a jitter-free hour, late polls, the info text, persistence and
//! corrupt images.

use ferrolink_runtime::modrob::engine::{Counters, MAX_RATE_MHZ};
use ferrolink_runtime::modrob::persist::{self, PersistError};
use ferrolink_runtime::modrob::{
    CommandKind, Dictionary, Direction, Engine, Handled, Message, SetError, Variable,
};
use proptest::prelude::*;

const fn var(
    vi: u8,
    name: &'static str,
    direction: Direction,
    (min, max): (f32, f32),
    default: f32,
    persist: bool,
    rate: f32,
) -> Variable {
    Variable {
        vi,
        name,
        unit: "1",
        direction,
        min,
        max,
        default,
        persist,
        rate,
        description: "",
    }
}

const SPEED_SETPOINT: u8 = 0;
const SPEED: u8 = 1;
const POSITION: u8 = 2;
const MODE: u8 = 5;
const GAIN: u8 = 9;

const DRIVE: Dictionary<5> = Dictionary {
    name: "drive",
    kind: "drive",
    module: 0x0110,
    uuid: None,
    info: "drive submodule: speed set point in m/s, speed and shaft position readings",
    fingerprint: 0x5EED_0001,
    variables: [
        var(
            SPEED_SETPOINT,
            "speed_setpoint",
            Direction::Input,
            (-10.0, 10.0),
            0.0,
            false,
            0.0,
        ),
        var(
            SPEED,
            "speed",
            Direction::Output,
            (-100.0, 100.0),
            0.0,
            false,
            100.0,
        ),
        var(
            POSITION,
            "position",
            Direction::Output,
            (-1e6, 1e6),
            0.0,
            false,
            100.0,
        ),
        var(MODE, "mode", Direction::Input, (0.0, 3.0), 0.0, true, 0.0),
        var(GAIN, "gain", Direction::Input, (0.0, 100.0), 1.0, true, 0.0),
    ],
};

/// The same table under another fingerprint.
const DRIVE_V2: Dictionary<5> = Dictionary {
    fingerprint: 0x5EED_0002,
    ..DRIVE
};

/// One input variable x, published at 100 Hz.
const RELAY: Dictionary<2> = Dictionary {
    name: "relay",
    kind: "relay",
    module: 1,
    uuid: None,
    info: "relay",
    fingerprint: 7,
    variables: [
        var(0, "x", Direction::Input, (-100.0, 100.0), 0.0, false, 100.0),
        var(
            1,
            "x_copy",
            Direction::Input,
            (-50.0, 50.0),
            0.0,
            false,
            0.0,
        ),
    ],
};

/// One output published at 3 Hz.
const SLOW: Dictionary<1> = Dictionary {
    name: "slow",
    kind: "slow",
    module: 3,
    uuid: None,
    info: "",
    fingerprint: 3,
    variables: [var(0, "y", Direction::Output, (-1.0, 1.0), 0.0, false, 3.0)],
};

fn set(module: u16, variable: u8, value: f32) -> Message {
    Message::Command {
        module,
        variable,
        command: CommandKind::SetValue(value),
    }
}

fn frequency(module: u16, variable: u8, hz: f32) -> Message {
    Message::Command {
        module,
        variable,
        command: CommandKind::SetFrequency(hz),
    }
}

fn subscribe(module: u16, variable: u8, source: (u16, u8)) -> Message {
    Message::Command {
        module,
        variable,
        command: CommandKind::SetSubscription {
            module: source.0,
            variable: source.1,
        },
    }
}

/// Every message due at `now`.
fn drain<const N: usize>(engine: &mut Engine<'_, N>, now: u64) -> Vec<Message> {
    std::iter::from_fn(|| engine.poll(now)).collect()
}

fn publications_of(messages: &[Message], vi: u8) -> usize {
    messages
        .iter()
        .filter(|m| matches!(m, Message::Publication { variable, .. } if *variable == vi))
        .count()
}

#[test]
fn limits_reject_and_count() {
    let mut drive = Engine::new(&DRIVE);
    let m = DRIVE.module;
    assert!(matches!(
        drive.handle(&set(m, SPEED_SETPOINT, 4.0)),
        Handled::Applied { variable: 0, .. }
    ));
    for bad in [10.5, -11.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert!(matches!(
            drive.handle(&set(m, SPEED_SETPOINT, bad)),
            Handled::Rejected { variable: 0, .. }
        ));
        assert_eq!(drive.value(SPEED_SETPOINT), Some(4.0));
    }
    // The limits themselves are accepted.
    drive.handle(&set(m, SPEED_SETPOINT, 10.0));
    drive.handle(&set(m, SPEED_SETPOINT, -10.0));
    assert_eq!(drive.value(SPEED_SETPOINT), Some(-10.0));
    // Unknown VI, another module's command, a piecewise chunk.
    assert_eq!(
        drive.handle(&set(m, 3, 1.0)),
        Handled::UnknownVariable { variable: 3 }
    );
    assert_eq!(
        drive.handle(&set(m + 1, SPEED_SETPOINT, 1.0)),
        Handled::Ignored
    );
    let chunk = Message::Piecewise {
        module: m,
        chunk: 0,
        chunks: 1,
        data: [0; 7],
    };
    assert_eq!(drive.handle(&chunk), Handled::Ignored);
    assert_eq!(
        *drive.counters(),
        Counters {
            commands: 9,
            rejected: 5,
            unknown_variable: 1,
            ..Counters::default()
        }
    );
    // The module's own sets obey the limits but are not counted.
    assert_eq!(drive.set(SPEED_SETPOINT, 11.0), Err(SetError::OutOfLimits));
    assert_eq!(drive.set(7, 1.0), Err(SetError::UnknownVariable));
    assert_eq!(drive.set(SPEED_SETPOINT, 2.0), Ok(()));
    assert_eq!(drive.counters().rejected, 5);
    assert_eq!(drive.take_changed(), Some(SPEED_SETPOINT));
    assert_eq!(drive.take_changed(), None);
}

#[test]
fn inputs_and_outputs() {
    let mut drive = Engine::new(&DRIVE);
    let m = DRIVE.module;
    drain(&mut drive, 0);
    // An input set from outside raises its flag; an output does not, but is published.
    drive.handle(&set(m, SPEED, 42.0));
    drive.handle(&set(m, GAIN, 2.0));
    drive.handle(&set(m, MODE, 1.0));
    assert_eq!(drive.take_changed(), Some(MODE));
    assert_eq!(drive.take_changed(), Some(GAIN));
    assert_eq!(drive.take_changed(), None);
    let out = drain(&mut drive, 10_000);
    assert!(out.contains(&Message::Publication {
        module: m,
        variable: SPEED,
        value: 42.0
    }));
    // The control code overwrites the reading; the next publication carries its value.
    drive.set(SPEED, 1.25).unwrap();
    let out = drain(&mut drive, 20_000);
    assert!(out.contains(&Message::Publication {
        module: m,
        variable: SPEED,
        value: 1.25
    }));
    // A new MI: commands to the old one are ignored, publications carry the new one.
    drive.set_module(0x0200);
    assert_eq!(drive.handle(&set(m, GAIN, 3.0)), Handled::Ignored);
    assert!(drive.handle(&set(0x0200, GAIN, 3.0)).is_for_us());
    assert!(drain(&mut drive, 30_000)
        .iter()
        .all(|message| message.module() == 0x0200));
}

#[test]
fn subscription_chain() {
    // A publishes x; B's x follows A.x; C's x follows B.x. B's x_copy also follows A.x.
    let (mut a, mut b, mut c) = (
        Engine::new(&RELAY),
        Engine::new(&RELAY),
        Engine::new(&RELAY),
    );
    b.set_module(2);
    c.set_module(3);
    for message in [
        subscribe(2, 0, (1, 0)),
        subscribe(2, 1, (1, 0)),
        subscribe(3, 0, (2, 0)),
    ] {
        for engine in [&mut a, &mut b, &mut c] {
            engine.handle(&message);
        }
    }
    assert_eq!(b.subscription(0), Some((1, 0)));
    assert_eq!(c.subscription(0), Some((2, 0)));
    assert_eq!(a.subscription(0), None);

    let mut last_x = 0.0;
    for ms in 0..2_000u64 {
        let now = ms * 1000;
        // A's control code moves x every 50 ms, between -60 and 60.
        if ms % 50 == 0 {
            last_x = ((ms / 50) % 13) as f32 * 10.0 - 60.0;
            a.set(0, last_x).unwrap();
        }
        let mut bus = Vec::new();
        for engine in [&mut a, &mut b, &mut c] {
            bus.extend(drain(engine, now));
        }
        for message in &bus {
            for engine in [&mut a, &mut b, &mut c] {
                engine.handle(message);
            }
        }
        // x reaches C two publications (at most 20 ms) after it changes.
        if ms % 50 == 30 {
            assert_eq!(b.value(0), Some(last_x), "at {ms} ms");
            assert_eq!(c.value(0), Some(last_x), "at {ms} ms");
            // x_copy follows too, within its narrower limits.
            if last_x.abs() <= 50.0 {
                assert_eq!(b.value(1), Some(last_x));
            }
        }
    }
    // A's 200 publications reached B; those outside x_copy's limits were refused.
    assert_eq!(
        b.counters().subscription_updates + b.counters().subscription_rejected,
        400
    );
    assert!(b.counters().subscription_rejected > 0);
    assert_eq!(c.counters().subscription_updates, 200);
    assert_eq!(a.counters().subscription_updates, 0);
    // Inputs set by a subscription raise their flag.
    assert_eq!(c.take_changed(), Some(0));

    // Subscribing to its own address clears a subscription.
    c.handle(&subscribe(3, 0, (3, 0)));
    assert_eq!(c.subscription(0), None);
    assert_eq!(
        c.handle(&Message::Publication {
            module: 2,
            variable: 0,
            value: 5.0
        }),
        Handled::Ignored
    );
}

#[test]
fn rate_changes() {
    let mut drive = Engine::new(&DRIVE);
    let m = DRIVE.module;
    drive.handle(&frequency(m, POSITION, 0.0));
    drain(&mut drive, 0);
    assert!(matches!(
        drive.handle(&frequency(m, SPEED, 50.0)),
        Handled::Applied { .. }
    ));
    assert_eq!(drive.rate(SPEED), Some(50.0));
    // The new schedule starts at the next poll: exactly 500 in the 10 s from it.
    let t0 = 5_000_000;
    let mut count = 0;
    for ms in 0..10_000 {
        count += publications_of(&drain(&mut drive, t0 + ms * 1000), SPEED);
    }
    assert_eq!(count, 500);
    assert_eq!(drive.counters().missed, 0);

    // Invalid rates are rejected and change nothing.
    for bad in [-1.0, f32::NAN, f32::INFINITY, 10_001.0] {
        assert!(matches!(
            drive.handle(&frequency(m, SPEED, bad)),
            Handled::Rejected { .. }
        ));
    }
    assert_eq!(drive.counters().rejected, 4);
    assert_eq!(drive.rate(SPEED), Some(50.0));

    // 0 stops publishing.
    drive.handle(&frequency(m, SPEED, 0.0));
    let t1 = 20_000_000;
    let mut count = 0;
    for ms in 0..10_000 {
        count += publications_of(&drain(&mut drive, t1 + ms * 1000), SPEED);
    }
    assert_eq!(count, 0);

    // Restarted: the first publication at the next poll, then every 20 ms.
    drive.handle(&frequency(m, SPEED, 50.0));
    let t2 = 40_000_123;
    assert_eq!(publications_of(&drain(&mut drive, t2), SPEED), 1);
    assert_eq!(publications_of(&drain(&mut drive, t2 + 19_999), SPEED), 0);
    assert_eq!(publications_of(&drain(&mut drive, t2 + 20_000), SPEED), 1);

    // A rate on a variable that had none.
    drive.handle(&frequency(m, GAIN, 1.0));
    assert_eq!(publications_of(&drain(&mut drive, t2 + 30_000), GAIN), 1);
    assert_eq!(drive.next_deadline(), Some(t2 + 40_000));
}

#[test]
fn jitter_free_hour() {
    let mut slow = Engine::new(&SLOW);
    let start = 1_000u64; // ms
    let mut times = Vec::new();
    for ms in start..start + 3_600_000 {
        let now = ms * 1000;
        while let Some(message) = slow.poll(now) {
            if let Message::Publication { .. } = message {
                times.push(now);
            }
        }
    }
    assert_eq!(times.len(), 3 * 3600);
    for (k, &t) in times.iter().enumerate() {
        let ideal = (start * 1000) as f64 + k as f64 * 1e6 / 3.0;
        let late = t as f64 - ideal;
        assert!((-1.0..1000.0).contains(&late), "publication {k} at {t} µs");
    }
    assert_eq!(slow.counters().missed, 0);
    assert_eq!(slow.counters().publications, 10_800);
}

#[test]
fn late_polls_skip_and_count() {
    let mut drive = Engine::new(&DRIVE);
    // The whole info text goes at the first poll, out of the way of the deadlines below.
    drive.set_info_interval(0);
    assert_eq!(publications_of(&drain(&mut drive, 0), SPEED), 1);
    // 100 Hz: due at 10, 20, 30, 40, 50 ms; a poll at 55 ms publishes once.
    let out = drain(&mut drive, 55_000);
    assert_eq!(publications_of(&out, SPEED), 1);
    assert_eq!(publications_of(&out, POSITION), 1);
    assert_eq!(drive.counters().missed, 2 * 4);
    // The grid keeps its phase.
    assert_eq!(drive.next_deadline(), Some(60_000));
    assert_eq!(publications_of(&drain(&mut drive, 59_999), SPEED), 0);
    assert_eq!(publications_of(&drain(&mut drive, 60_000), SPEED), 1);
    assert_eq!(drive.counters().missed, 8);
    assert_eq!(drive.counters().publications, 6);
}

fn reassemble(chunks: &[Message]) -> String {
    let mut bytes = Vec::new();
    for (i, chunk) in chunks.iter().enumerate() {
        let Message::Piecewise {
            chunk: n,
            chunks: total,
            data,
            ..
        } = chunk
        else {
            panic!("not a chunk: {chunk:?}");
        };
        assert_eq!(usize::from(*n), i);
        assert_eq!(usize::from(*total), chunks.len());
        bytes.extend_from_slice(data);
    }
    while bytes.last() == Some(&0) {
        bytes.pop();
    }
    String::from_utf8(bytes).unwrap()
}

#[test]
fn info_text_after_first_poll() {
    let mut drive = Engine::new(&DRIVE);
    drive.set_rate(SPEED, 0.0).unwrap();
    drive.set_rate(POSITION, 0.0).unwrap();
    let mut chunks = Vec::new();
    let mut times = Vec::new();
    for us in (0..100_000).step_by(100) {
        for message in drain(&mut drive, us) {
            chunks.push(message);
            times.push(us);
        }
    }
    assert_eq!(reassemble(&chunks), DRIVE.info);
    assert_eq!(chunks.len(), DRIVE.info.len().div_ceil(7));
    // One chunk per millisecond, from the first poll.
    assert!(times.iter().enumerate().all(|(i, &t)| t == i as u64 * 1000));
    assert_eq!(drive.counters().chunks as usize, chunks.len());
    assert!(!drive.is_announcing());
    assert_eq!(drive.next_deadline(), None);

    // Announcing again, all at once, publications first.
    drive.set_rate(SPEED, 10.0).unwrap();
    drive.set_info_interval(0);
    drive.announce();
    let out = drain(&mut drive, 200_000);
    assert!(matches!(
        out[0],
        Message::Publication {
            variable: SPEED,
            ..
        }
    ));
    assert_eq!(reassemble(&out[1..]), DRIVE.info);
}

/// A drive with every kind of setting changed.
fn changed_drive() -> Engine<'static, 5> {
    let mut drive = Engine::new(&DRIVE);
    let m = DRIVE.module;
    drive.handle(&set(m, MODE, 2.0));
    drive.handle(&set(m, GAIN, 5.5));
    drive.handle(&set(m, SPEED_SETPOINT, 3.0));
    drive.handle(&frequency(m, SPEED, 1.0 / 3.0));
    drive.handle(&frequency(m, POSITION, 0.0));
    drive.handle(&frequency(m, GAIN, 2.0));
    drive.handle(&subscribe(m, SPEED_SETPOINT, (0x0042, 7)));
    drive.handle(&subscribe(m, MODE, (0xffff, 255)));
    drive
}

#[test]
fn persistence_round_trip() {
    let drive = changed_drive();
    let mut image = [0u8; Engine::<5>::IMAGE_LEN];
    assert_eq!(drive.save(&mut image), Ok(image.len()));
    assert_eq!(image.len(), 15 + 13 * 5);

    let mut fresh = Engine::new(&DRIVE);
    fresh.load(&image).unwrap();
    // Persistent values, every rate and subscription; the set point is not persistent.
    assert_eq!(fresh.value(MODE), Some(2.0));
    assert_eq!(fresh.value(GAIN), Some(5.5));
    assert_eq!(fresh.value(SPEED_SETPOINT), Some(0.0));
    assert_eq!(fresh.settings().rates, drive.settings().rates);
    assert_eq!(fresh.rate_mhz(SPEED), Some(333));
    assert_eq!(fresh.subscription(SPEED_SETPOINT), Some((0x0042, 7)));
    assert_eq!(fresh.subscription(MODE), Some((0xffff, 255)));
    assert_eq!(fresh.take_changed(), None);
    let mut again = [0u8; Engine::<5>::IMAGE_LEN];
    fresh.save(&mut again).unwrap();
    assert_eq!(again, image);

    // The loaded schedules run from the next poll.
    let out = drain(&mut fresh, 7_000);
    assert_eq!(publications_of(&out, SPEED), 1);
    assert_eq!(publications_of(&out, POSITION), 0);
    assert_eq!(publications_of(&out, GAIN), 1);

    // An image in a larger flash page loads; a short buffer does not save.
    let mut page = [0xffu8; 256];
    page[..image.len()].copy_from_slice(&image);
    assert_eq!(persist::check(&DRIVE, &page), Ok(image.len()));
    assert_eq!(
        drive.save(&mut page[..image.len() - 1]),
        Err(PersistError::BufferTooSmall {
            needed: image.len(),
            got: image.len() - 1
        })
    );
}

#[test]
fn corrupt_images_are_refused() {
    let drive = changed_drive();
    let mut image = [0u8; Engine::<5>::IMAGE_LEN];
    drive.save(&mut image).unwrap();
    let defaults = Engine::new(&DRIVE).settings().clone();

    let mut target = Engine::new(&DRIVE);
    for bit in 0..image.len() * 8 {
        let mut bad = image;
        bad[bit / 8] ^= 1 << (bit % 8);
        assert!(target.load(&bad).is_err(), "bit {bit} flipped was accepted");
        assert_eq!(*target.settings(), defaults);
    }
    for len in 0..image.len() {
        assert!(
            matches!(
                target.load(&image[..len]),
                Err(PersistError::Truncated { .. })
            ),
            "{len} bytes"
        );
    }
    let mut other = Engine::new(&DRIVE_V2);
    assert_eq!(
        other.load(&image),
        Err(PersistError::WrongDictionary {
            expected: 0x5EED_0002,
            found: 0x5EED_0001
        })
    );
    assert_eq!(*other.settings(), defaults);
    assert_eq!(*target.settings(), defaults);
    // Specific corruptions report what they are.
    let mut bad = image;
    bad[0] = b'X';
    assert_eq!(target.load(&bad), Err(PersistError::BadMagic));
    bad = image;
    bad[4] = 2;
    assert_eq!(target.load(&bad), Err(PersistError::UnsupportedVersion(2)));
    bad = image;
    bad[20] ^= 0x10;
    assert!(matches!(
        target.load(&bad),
        Err(PersistError::BadChecksum { .. })
    ));
}

/// Mode, gain, rates (mHz) and subscriptions of the drive.
type DriveState = (f32, f32, [u32; 5], [Option<(u16, u8)>; 5]);

/// An arbitrary valid state of the drive: persistent values within limits, any rate up to the
/// maximum, any subscription.
fn drive_state() -> impl Strategy<Value = DriveState> {
    (
        0.0f32..=3.0,
        0.0f32..=100.0,
        prop::array::uniform5(prop_oneof![Just(0u32), 1..=MAX_RATE_MHZ]),
        prop::array::uniform5(prop::option::of((any::<u16>(), any::<u8>()))),
    )
}

/// One record, mostly near valid: a known VI, defined flags, a value in range or zero, a rate
/// around the maximum, zero subscription bytes; sometimes anything.
fn record() -> impl Strategy<Value = Vec<u8>> {
    (
        prop_oneof![
            3 => prop::sample::select(vec![SPEED_SETPOINT, SPEED, POSITION, MODE, GAIN]),
            1 => any::<u8>(),
        ],
        prop_oneof![3 => 0u8..4, 1 => any::<u8>()],
        prop_oneof![
            Just(0u32),
            (0.0f32..=3.0).prop_map(f32::to_bits),
            any::<u32>()
        ],
        prop_oneof![0..=MAX_RATE_MHZ + 10, any::<u32>()],
        prop_oneof![Just([0u8; 3]), any::<[u8; 3]>()],
    )
        .prop_map(|(vi, flags, value, rate, subscription)| {
            let mut record = vec![vi, flags];
            record.extend(value.to_le_bytes());
            record.extend(rate.to_le_bytes());
            record.extend(subscription);
            record
        })
}

/// A well-formed header and CRC around `records`, so the record checks are reached.
fn sealed(records: &[Vec<u8>]) -> Vec<u8> {
    let mut image = b"MR1P\x01".to_vec();
    image.extend_from_slice(&DRIVE.fingerprint.to_le_bytes());
    image.extend_from_slice(&(records.len() as u16).to_le_bytes());
    image.extend(records.concat());
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&image);
    image.extend_from_slice(&crc.to_le_bytes());
    image
}

proptest! {
    #[test]
    fn load_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..200)) {
        let mut drive = Engine::new(&DRIVE);
        let before = drive.settings().clone();
        if drive.load(&bytes).is_err() {
            prop_assert_eq!(drive.settings(), &before);
        }
    }

    #[test]
    fn sealed_records_never_panic(records in prop::collection::vec(record(), 0..7)) {
        let image = sealed(&records);
        let mut drive = Engine::new(&DRIVE);
        let before = drive.settings().clone();
        match drive.load(&image) {
            Ok(()) => {
                // Whatever loaded is valid: it saves and loads again to the same state.
                let mut buf = [0u8; Engine::<5>::IMAGE_LEN];
                drive.save(&mut buf).unwrap();
                let mut copy = Engine::new(&DRIVE);
                copy.load(&buf).unwrap();
                prop_assert_eq!(copy.settings(), drive.settings());
            }
            Err(_) => prop_assert_eq!(drive.settings(), &before),
        }
    }

    #[test]
    fn save_load_round_trip((mode, gain, rates, subscriptions) in drive_state()) {
        let mut drive = Engine::new(&DRIVE);
        drive.set(MODE, mode).unwrap();
        drive.set(GAIN, gain).unwrap();
        for (variable, (&rate, &subscription)) in
            DRIVE.variables.iter().zip(rates.iter().zip(&subscriptions))
        {
            drive.set_rate_mhz(variable.vi, rate).unwrap();
            drive.set_subscription(variable.vi, subscription).unwrap();
        }
        let mut image = [0u8; Engine::<5>::IMAGE_LEN];
        drive.save(&mut image).unwrap();
        let mut fresh = Engine::new(&DRIVE);
        fresh.load(&image).unwrap();
        prop_assert_eq!(fresh.settings(), drive.settings());
    }
}
