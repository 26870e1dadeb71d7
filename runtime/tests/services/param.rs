//! The parameter client and server: encodings, then both sides through a lossy link.

use ferrolink_runtime::mavlink::service::messages::{
    Heartbeat, MavAutopilot, MavParamExtType, MavParamType, Message, ParamAck, ParamExtAck,
    ParamExtSet, ParamExtValue, ParamSet, ParamValue,
};
use ferrolink_runtime::mavlink::service::param::{
    Bytes, Client, ClientConfig, Encoding, Event, Name, Param, Protocol, Received, Server,
    ServerConfig, Store, Value, LIST_BURST,
};
use ferrolink_runtime::mavlink::service::Address;
use proptest::prelude::*;

use super::lossy::{Faults, Node, Sim};

const GCS: Address = Address::new(255, 190);
const VEHICLE: Address = Address::new(1, 1);

#[test]
fn bytewise_puts_the_integers_bytes_in_the_float() {
    let cases = [
        (Value::U8(200), 0x0000_00c8),
        (Value::I8(-1), 0x0000_00ff),
        (Value::U16(0xbeef), 0x0000_beef),
        (Value::I16(-2), 0x0000_fffe),
        (Value::U32(0xdead_beef), 0xdead_beef),
        (Value::I32(-1), 0xffff_ffff),
        (Value::I32(1), 0x0000_0001),
        (Value::F32(1.5), 0x3fc0_0000),
    ];
    for (v, bits) in cases {
        let raw = v.encode(Encoding::Bytewise);
        assert_eq!(raw.to_bits(), bits, "{v:?}");
        let back = Value::decode(raw, v.param_type(), Encoding::Bytewise).unwrap();
        assert!(back.same(v), "{v:?} came back as {back:?}");
    }
}

#[test]
fn c_cast_converts_the_number() {
    for v in [
        Value::U8(200),
        Value::I8(-100),
        Value::U16(65535),
        Value::I16(-32768),
        Value::U32(16_777_216),
        Value::I32(-16_777_216),
        Value::I32(1),
    ] {
        let raw = v.encode(Encoding::CCast);
        assert_eq!(f64::from(raw), v.as_f64(), "{v:?}");
        assert!(Value::decode(raw, v.param_type(), Encoding::CCast)
            .unwrap()
            .same(v));
    }
    // Past 2^24 a float cannot hold every integer: the C cast loses the low bits, as on
    // ArduPilot; bytewise does not.
    let big = Value::I32(16_777_217);
    assert_eq!(
        Value::decode(
            big.encode(Encoding::CCast),
            MavParamType::Int32,
            Encoding::CCast
        ),
        Some(Value::I32(16_777_216))
    );
    assert_eq!(
        Value::decode(
            big.encode(Encoding::Bytewise),
            MavParamType::Int32,
            Encoding::Bytewise
        ),
        Some(big)
    );
}

#[test]
fn the_encoding_follows_the_autopilot() {
    assert_eq!(
        Encoding::for_autopilot(MavAutopilot::Ardupilotmega),
        Encoding::CCast
    );
    assert_eq!(
        Encoding::for_autopilot(MavAutopilot::Px4),
        Encoding::Bytewise
    );
    assert_eq!(
        Encoding::for_autopilot(MavAutopilot::Generic),
        Encoding::Bytewise
    );
    let mut c: Client<1> = Client::new(ClientConfig::new(GCS), VEHICLE);
    let hb = |autopilot| {
        Message::Heartbeat(Heartbeat {
            autopilot,
            ..Default::default()
        })
    };
    c.handle(0, Address::new(9, 1), &hb(MavAutopilot::Ardupilotmega));
    assert_eq!(
        c.encoding(),
        Encoding::Bytewise,
        "another system's heartbeat"
    );
    c.handle(0, VEHICLE, &hb(MavAutopilot::Ardupilotmega));
    assert_eq!(c.encoding(), Encoding::CCast);
    let mut forced = ClientConfig::new(GCS);
    forced.encoding = Some(Encoding::Bytewise);
    let mut c: Client<1> = Client::new(forced, VEHICLE);
    c.handle(0, VEHICLE, &hb(MavAutopilot::Ardupilotmega));
    assert_eq!(c.encoding(), Encoding::Bytewise);
}

#[test]
fn conversions_are_exact_or_refused() {
    assert_eq!(
        Value::from_f64(MavParamType::Uint8, 255.0),
        Some(Value::U8(255))
    );
    assert_eq!(Value::from_f64(MavParamType::Uint8, 256.0), None);
    assert_eq!(Value::from_f64(MavParamType::Int8, -1.5), None);
    assert_eq!(Value::from_f64(MavParamType::Int32, f64::NAN), None);
    assert_eq!(
        Value::from_f64(MavParamType::Uint64, 1.0),
        Some(Value::U64(1))
    );
    assert_eq!(Value::from_f64(MavParamType::Uint64, -1.0), None);
    assert_eq!(
        Value::I64(-(1 << 60)).convert(MavParamType::Real64),
        Some(Value::F64(-1152921504606846976.0))
    );
    assert_eq!(
        Value::F64(1e19).convert(MavParamType::Uint64),
        Some(Value::U64(10_000_000_000_000_000_000))
    );
    assert_eq!(Value::F64(1e19).convert(MavParamType::Int64), None);
    assert_eq!(
        Value::I16(7).convert(MavParamType::Real32),
        Some(Value::F32(7.0))
    );
}

fn name(s: &str) -> Name {
    Name::from(s)
}

/// A store of `n` parameters of every type PARAM_VALUE carries, with values that use all
/// their bits.
fn store(n: u16, seed: u64) -> Vec<Param> {
    store_of(n, seed, 7)
}

/// A store of `n` parameters of the first `types` of U8, I8, U16, I16, U32, I32, F32, U64,
/// I64 and F64.
fn store_of(n: u16, seed: u64, types: u16) -> Vec<Param> {
    let mut x = seed | 1;
    (0..n)
        .map(|i| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let value = match i % types {
                0 => Value::U8(x as u8),
                1 => Value::I8(x as i8),
                2 => Value::U16(x as u16),
                3 => Value::I16(x as i16),
                4 => Value::U32(x as u32),
                5 => Value::I32(x as i32),
                // Any bits but NaNs, whose payloads no peer promises to keep.
                6 => Value::F32(f32::from_bits(x as u32 & 0xbfff_ffff)),
                7 => Value::U64(x),
                8 => Value::I64(x as i64),
                _ => Value::F64(f64::from_bits(x & 0xbfff_ffff_ffff_ffff)),
            };
            Param {
                name: name(&format!("P{i:04}_{}", i % types)),
                value,
            }
        })
        .collect()
}

struct Gcs {
    client: Client<64>,
    got: Vec<Received>,
    events: Vec<Event>,
}

impl Node for Gcs {
    fn address(&self) -> Address {
        GCS
    }
    fn handle(&mut self, now: u64, from: Address, msg: &Message) {
        if let Some(r) = self.client.handle(now, from, msg) {
            self.got.push(r);
        }
        self.events.extend(self.client.poll_event());
    }
    fn poll_transmit(&mut self, now: u64) -> Option<Message> {
        let m = self.client.poll_transmit(now);
        self.events.extend(self.client.poll_event());
        m
    }
    fn poll_timeout(&self) -> Option<u64> {
        self.client.poll_timeout()
    }
}

struct Vehicle {
    server: Server<8>,
    params: Vec<Param>,
    requests: usize,
}

impl Node for Vehicle {
    fn address(&self) -> Address {
        VEHICLE
    }
    fn handle(&mut self, now: u64, from: Address, msg: &Message) {
        self.requests += 1;
        self.server.handle(&mut self.params[..], now, from, msg);
    }
    fn poll_transmit(&mut self, now: u64) -> Option<Message> {
        self.server.poll_transmit(&self.params[..], now)
    }
    fn poll_timeout(&self) -> Option<u64> {
        self.server.poll_timeout()
    }
}

fn pair(n: u16, encoding: Encoding) -> (Gcs, Vehicle) {
    pair_in(n, encoding, Protocol::V1)
}

fn pair_in(n: u16, encoding: Encoding, protocol: Protocol) -> (Gcs, Vehicle) {
    let mut config = ClientConfig::new(GCS);
    config.encoding = Some(encoding);
    config.protocol = protocol;
    let mut server = ServerConfig::new(VEHICLE);
    server.encoding = encoding;
    server.list_interval_us = 200;
    (
        Gcs {
            client: Client::new(config, VEHICLE),
            got: Vec::new(),
            events: Vec::new(),
        },
        Vehicle {
            server: Server::new(server),
            params: match protocol {
                Protocol::V1 => store(n, 7),
                Protocol::Ext => store_of(n, 7, 10),
            },
            requests: 0,
        },
    )
}

/// Lists through `faults` and checks the client's table against the vehicle's.
fn list(seed: u64, faults: Faults, gcs: &mut Gcs, vehicle: &mut Vehicle) {
    let mut sim = Sim::new(seed, faults);
    gcs.client.list().unwrap();
    finish_list(&mut sim, gcs, vehicle);
}

fn finish_list(sim: &mut Sim, gcs: &mut Gcs, vehicle: &mut Vehicle) {
    let ended = sim.run(gcs, vehicle, 600_000_000, |g, _| !g.events.is_empty());
    assert!(ended, "the list never ended");
    let count = vehicle.params.len() as u16;
    assert_eq!(gcs.events, [Event::Listed { count, missing: 0 }]);
    for (i, p) in vehicle.params.iter().enumerate() {
        let r = gcs
            .got
            .iter()
            .rev()
            .find(|r| r.index as usize == i && r.count == count)
            .unwrap_or_else(|| panic!("index {i} never arrived"));
        assert_eq!(r.name, p.name);
        assert!(
            r.value.unwrap().same(p.value),
            "{}: {:?} != {:?}",
            p.name,
            r.value,
            p.value
        );
    }
}

#[test]
fn a_cached_copy_with_the_same_hash_check_stops_the_list() {
    let (mut gcs, mut vehicle) = pair(300, Encoding::Bytewise);
    let mut config = *vehicle.server.config();
    config.hash_check = true;
    vehicle.server = Server::new(config);
    // A first list announces the hash and still brings every value.
    list(3, Faults::CLEAN, &mut gcs, &mut vehicle);
    let hash = gcs.client.announced_hash().expect("a _HASH_CHECK");
    assert_eq!(
        hash,
        ferrolink_runtime::mavlink::service::param::hash::hash(&vehicle.params[..])
    );
    // With the same hash cached, the list stops at the hash: only what the stream sent in the
    // round trip before the stop arrived (10 ms at a value per 200 µs) goes out.
    gcs.got.clear();
    gcs.events.clear();
    let mut sim = Sim::new(4, Faults::CLEAN);
    gcs.client.list_unless(hash).unwrap();
    let ended = sim.run(&mut gcs, &mut vehicle, 10_000_000, |g, _| {
        !g.events.is_empty()
    });
    assert!(ended);
    assert_eq!(gcs.events, [Event::Unchanged { count: 300, hash }]);
    sim.run(&mut gcs, &mut vehicle, sim.now_us + 1_000_000, |_, _| false);
    assert!(
        gcs.got.len() <= 55,
        "{} values after the stop",
        gcs.got.len()
    );
    // A changed parameter changes the hash: the list runs in full.
    vehicle.params[7].value = Value::F32(1234.5);
    gcs.got.clear();
    gcs.events.clear();
    gcs.client.list_unless(hash).unwrap();
    finish_list(&mut sim, &mut gcs, &mut vehicle);
    assert_ne!(gcs.client.announced_hash(), Some(hash));
}

#[test]
fn a_clean_list_needs_no_re_requests() {
    for encoding in [Encoding::Bytewise, Encoding::CCast] {
        let (mut gcs, mut vehicle) = pair(300, encoding);
        if encoding == Encoding::CCast {
            // Only values a float holds exactly survive the cast.
            for p in &mut vehicle.params {
                if let Value::U32(v) = p.value {
                    p.value = Value::U32(v & 0xff_ffff);
                }
                if let Value::I32(v) = p.value {
                    p.value = Value::I32(v >> 8);
                }
            }
        }
        list(1, Faults::CLEAN, &mut gcs, &mut vehicle);
        assert_eq!(gcs.got.len(), 300, "{encoding:?}: each value once");
        assert_eq!(vehicle.requests, 1);
    }
}

#[test]
fn a_list_that_changes_midway_is_counted_again() {
    let (mut gcs, mut vehicle) = pair(100, Encoding::Bytewise);
    let mut sim = Sim::new(3, Faults::BAD_RADIO);
    gcs.client.list().unwrap();
    sim.run(&mut gcs, &mut vehicle, 10_000, |_, _| false);
    assert!(!gcs.got.is_empty() && gcs.events.is_empty());
    // 20 parameters appear, and another ground station's request restarts the stream.
    let more = store(120, 99);
    vehicle.params.extend_from_slice(&more[100..]);
    let request = Message::ParamRequestList(Default::default());
    vehicle.server.handle(
        &mut vehicle.params[..],
        sim.now_us,
        Address::new(254, 1),
        &request,
    );
    finish_list(&mut sim, &mut gcs, &mut vehicle);
}

#[test]
fn get_and_set_round_trip_every_type() {
    for encoding in [Encoding::Bytewise, Encoding::CCast] {
        let (mut gcs, mut vehicle) = pair(7, encoding);
        let mut sim = Sim::new(5, Faults::CLEAN);
        for i in 0..7u16 {
            let p = vehicle.params[usize::from(i)];
            let new = match p.value {
                Value::U8(_) => Value::U8(254),
                Value::I8(_) => Value::I8(-128),
                Value::U16(_) => Value::U16(65_000),
                Value::I16(_) => Value::I16(-30_000),
                Value::U32(_) => Value::U32(16_000_000),
                Value::I32(_) => Value::I32(-16_000_000),
                Value::F32(_) => Value::F32(-0.125),
                other => unreachable!("{other:?}: not in a V1 store"),
            };
            gcs.client.set(p.name, new).unwrap();
            sim.run(&mut gcs, &mut vehicle, sim.now_us + 10_000_000, |g, _| {
                !g.events.is_empty()
            });
            let Some(Event::Set(Some(r))) = gcs.events.pop() else {
                panic!("{encoding:?} {p:?}")
            };
            assert!(r.value.unwrap().same(new), "{encoding:?}: {r:?}");
            assert!(vehicle.params[usize::from(i)].value.same(new));
            gcs.client.read(p.name).unwrap();
            sim.run(&mut gcs, &mut vehicle, sim.now_us + 10_000_000, |g, _| {
                !g.events.is_empty()
            });
            let Some(Event::Read(Some(r))) = gcs.events.pop() else {
                panic!()
            };
            assert_eq!(r.index, i);
            gcs.client.read_index(i).unwrap();
            sim.run(&mut gcs, &mut vehicle, sim.now_us + 10_000_000, |g, _| {
                !g.events.is_empty()
            });
            let Some(Event::Read(Some(r))) = gcs.events.pop() else {
                panic!()
            };
            assert_eq!(r.name, p.name);
        }
    }
}

#[test]
fn a_set_the_vehicle_cannot_hold_reports_what_it_holds() {
    let mut params = store(7, 7);
    let mut server: Server<4> = Server::new(ServerConfig::new(VEHICLE));
    // 300 for a UINT8 parameter, sent as REAL32: refused, and the old value comes back.
    let set = Message::ParamSet(ParamSet {
        target_system: 1,
        target_component: 1,
        param_id: params[0].name,
        param_value: 300.0,
        param_type: MavParamType::Real32,
    });
    let before = params[0].value;
    server.handle(&mut params[..], 0, GCS, &set);
    assert!(params[0].value.same(before));
    let Some(Message::ParamValue(ParamValue {
        param_value,
        param_type,
        ..
    })) = server.poll_transmit(&params[..], 0)
    else {
        panic!()
    };
    assert_eq!(param_type, MavParamType::Uint8);
    assert!(Value::decode(param_value, param_type, Encoding::Bytewise)
        .unwrap()
        .same(before));
    // 7.0 as REAL32 for it: converted and taken.
    let Message::ParamSet(mut ok) = set else {
        unreachable!()
    };
    ok.param_value = 7.0;
    server.handle(&mut params[..], 0, GCS, &Message::ParamSet(ok));
    assert_eq!(params[0].value, Value::U8(7));
    // An unknown name: nothing.
    ok.param_id = name("NOPE");
    server.handle(&mut params[..], 0, GCS, &Message::ParamSet(ok));
    assert!(server.poll_transmit(&params[..], 0).is_some());
    assert!(server.poll_transmit(&params[..], 0).is_none());
    assert_eq!(Store::count(&params[..]), 7);
}

#[test]
fn a_client_gives_up_when_nothing_answers() {
    let mut c: Client<4> = Client::new(ClientConfig::new(GCS), VEHICLE);
    c.list().unwrap();
    let mut sent = 0;
    let mut now = 0;
    while !c.is_idle() {
        while c.poll_transmit(now).is_some() {
            sent += 1;
        }
        now = c.poll_timeout().map_or(now, |t| t.max(now + 1));
    }
    // No round trip measured: twelve requests 1 s apart, as `Retry::exhausted` asks.
    assert_eq!(sent, 12);
    assert_eq!(
        c.poll_event(),
        Some(Event::Listed {
            count: 0,
            missing: 0
        })
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]
    /// Through a link that loses 20 %, repeats 5 % and reorders, the whole list arrives, every
    /// value bit-exact.
    #[test]
    fn a_bad_radio_loses_no_parameter(seed in any::<u64>(), n in 1u16..700) {
        let (mut gcs, mut vehicle) = pair(n, Encoding::Bytewise);
        list(seed, Faults::BAD_RADIO, &mut gcs, &mut vehicle);
    }

    /// The same through PARAM_EXT_*, with the 64-bit types among the values.
    #[test]
    fn a_bad_radio_loses_no_extended_parameter(seed in any::<u64>(), n in 1u16..400) {
        let (mut gcs, mut vehicle) = pair_in(n, Encoding::Bytewise, Protocol::Ext);
        list(seed, Faults::BAD_RADIO, &mut gcs, &mut vehicle);
    }
}

#[test]
fn an_extended_list_carries_64_bit_values_whole() {
    let (mut gcs, mut vehicle) = pair_in(50, Encoding::CCast, Protocol::Ext);
    list(11, Faults::CLEAN, &mut gcs, &mut vehicle);
    assert_eq!(gcs.got.len(), 50, "each value once");
    // A V1 client of the same vehicle lists every index, the 64-bit ones without a value.
    let (mut v1, _) = pair(0, Encoding::Bytewise);
    let mut sim = Sim::new(12, Faults::CLEAN);
    v1.client.list().unwrap();
    sim.run(&mut v1, &mut vehicle, 600_000_000, |g, _| {
        !g.events.is_empty()
    });
    assert_eq!(
        v1.events,
        [Event::Listed {
            count: 50,
            missing: 0
        }]
    );
    for r in &v1.got {
        let wide = vehicle.params[usize::from(r.index)]
            .value
            .param_type()
            .raw()
            >= 7
            && vehicle.params[usize::from(r.index)].value.param_type() != MavParamType::Real32;
        assert_eq!(r.value.is_none(), wide, "{r:?}");
    }
}

/// Runs `gcs` against `vehicle` until the client's operation ends, and returns its event.
fn run_op(sim: &mut Sim, gcs: &mut Gcs, vehicle: &mut Vehicle) -> Event {
    sim.run(gcs, vehicle, sim.now_us + 30_000_000, |g, _| {
        !g.events.is_empty()
    });
    gcs.events.pop().expect("the operation never ended")
}

#[test]
fn extended_get_and_set_round_trip_every_type() {
    let (mut gcs, mut vehicle) = pair_in(10, Encoding::Bytewise, Protocol::Ext);
    let mut sim = Sim::new(5, Faults::BAD_RADIO);
    for i in 0..10u16 {
        let p = vehicle.params[usize::from(i)];
        let new = match p.value {
            Value::U8(_) => Value::U8(254),
            Value::I8(_) => Value::I8(-128),
            Value::U16(_) => Value::U16(65_000),
            Value::I16(_) => Value::I16(-30_000),
            Value::U32(_) => Value::U32(u32::MAX),
            Value::I32(_) => Value::I32(-16_000_001),
            Value::U64(_) => Value::U64(u64::MAX - 2),
            Value::I64(_) => Value::I64(i64::MIN + 1),
            Value::F32(_) => Value::F32(-0.1),
            Value::F64(_) => Value::F64(-0.1),
        };
        gcs.client.set(p.name, new).unwrap();
        let Event::Set(Some(r)) = run_op(&mut sim, &mut gcs, &mut vehicle) else {
            panic!("{p:?}")
        };
        assert!(r.value.unwrap().same(new), "{r:?}");
        assert!(vehicle.params[usize::from(i)].value.same(new));
        gcs.client.read(p.name).unwrap();
        let Event::Read(Some(r)) = run_op(&mut sim, &mut gcs, &mut vehicle) else {
            panic!()
        };
        assert_eq!(r.index, i);
        assert!(r.value.unwrap().same(new), "{r:?}");
        gcs.client.read_index(i).unwrap();
        let Event::Read(Some(r)) = run_op(&mut sim, &mut gcs, &mut vehicle) else {
            panic!()
        };
        assert_eq!(r.name, p.name);
    }
    // A value the parameter's type cannot hold: refused, and the client says so.
    let p = vehicle.params[0];
    gcs.client.set(p.name, Value::F64(0.5)).unwrap();
    let Event::Set(Some(r)) = run_op(&mut sim, &mut gcs, &mut vehicle) else {
        panic!()
    };
    assert_eq!(r.value, None);
    assert!(vehicle.params[0].value.same(Value::U8(254)));
}

#[test]
fn extended_sets_are_acknowledged_with_the_result() {
    let mut params = store_of(10, 3, 10);
    let mut server: Server<4> = Server::new(ServerConfig::new(VEHICLE));
    let set = |name: Name, value: Value| {
        Message::ParamExtSet(ParamExtSet {
            target_system: 1,
            target_component: 0,
            param_id: name,
            param_value: value.to_ext(),
            param_type: value.ext_type(),
        })
    };
    let ack = |server: &mut Server<4>, params: &[Param]| match server.poll_transmit(params, 0) {
        Some(Message::ParamExtAck(a)) => a,
        other => panic!("{other:?}"),
    };
    // The exact number in another type: converted and accepted.
    let m = set(params[7].name, Value::F64(4e18));
    server.handle(&mut params[..], 0, GCS, &m);
    let a = ack(&mut server, &params);
    assert_eq!(a.param_result, ParamAck::Accepted);
    assert_eq!(a.param_type, MavParamExtType::Uint64);
    assert_eq!(
        Value::from_ext(&a.param_value, a.param_type),
        Some(Value::U64(4_000_000_000_000_000_000))
    );
    // Out of range: VALUE_UNSUPPORTED, with the value held.
    let before = params[0].value;
    let m = set(params[0].name, Value::I32(256));
    server.handle(&mut params[..], 0, GCS, &m);
    let ParamExtAck {
        param_result,
        param_value,
        param_type,
        ..
    } = ack(&mut server, &params);
    assert_eq!(param_result, ParamAck::ValueUnsupported);
    assert!(Value::from_ext(&param_value, param_type)
        .unwrap()
        .same(before));
    // A store that refuses: FAILED.
    struct ReadOnly(Vec<Param>);
    impl Store for ReadOnly {
        fn count(&self) -> u16 {
            self.0[..].count()
        }
        fn get(&self, index: u16) -> Option<Param> {
            self.0[..].get(usize::from(index)).copied()
        }
        fn index_of(&self, name: &Name) -> Option<u16> {
            self.0[..].index_of(name)
        }
        fn set(&mut self, _: u16, _: Value) -> Option<Value> {
            None
        }
    }
    let mut ro = ReadOnly(params.clone());
    server.handle(&mut ro, 0, GCS, &set(params[1].name, Value::I8(1)));
    let Some(Message::ParamExtAck(a)) = server.poll_transmit(&ro, 0) else {
        panic!()
    };
    assert_eq!(a.param_result, ParamAck::Failed);
    // CUSTOM: unsupported; an unknown name: no answer.
    let mut custom = set(params[2].name, Value::U8(0));
    if let Message::ParamExtSet(m) = &mut custom {
        m.param_type = MavParamExtType::Custom;
    }
    server.handle(&mut params[..], 0, GCS, &custom);
    assert_eq!(
        ack(&mut server, &params).param_result,
        ParamAck::ValueUnsupported
    );
    server.handle(&mut params[..], 0, GCS, &set(name("NOPE"), Value::U8(0)));
    assert!(server.poll_transmit(&params[..], 0).is_none());
}

#[test]
fn in_progress_keeps_an_extended_set_waiting() {
    let mut config = ClientConfig::new(GCS);
    config.protocol = Protocol::Ext;
    let mut c: Client<1> = Client::new(config, VEHICLE);
    let p = name("CAM_EV");
    c.set(p, Value::F32(1.5)).unwrap();
    assert!(matches!(c.poll_transmit(0), Some(Message::ParamExtSet(_))));
    let ack = |result: ParamAck, value: Value| {
        Message::ParamExtAck(ParamExtAck {
            param_id: p,
            param_value: value.to_ext(),
            param_type: value.ext_type(),
            param_result: result,
        })
    };
    // A PARAM_EXT_VALUE does not answer a set, nor does a V1 answer.
    let value = Message::ParamExtValue(ParamExtValue {
        param_id: p,
        param_value: Value::F32(0.0).to_ext(),
        param_type: MavParamExtType::Real32,
        param_count: 1,
        param_index: 0,
    });
    c.handle(10_000, VEHICLE, &value);
    c.handle(10_000, VEHICLE, &Message::ParamValue(ParamValue::default()));
    assert_eq!(c.poll_event(), None);
    // IN_PROGRESS: no resending before the longest wait (1 s) has passed since.
    c.handle(20_000, VEHICLE, &ack(ParamAck::InProgress, Value::F32(0.0)));
    assert_eq!(c.poll_timeout(), Some(1_020_000));
    assert!(c.poll_transmit(1_000_000).is_none());
    c.handle(
        1_500_000,
        VEHICLE,
        &ack(ParamAck::InProgress, Value::F32(0.0)),
    );
    assert!(c.poll_transmit(2_000_000).is_none());
    c.handle(
        2_100_000,
        VEHICLE,
        &ack(ParamAck::Accepted, Value::F32(1.5)),
    );
    let Some(Event::Set(Some(r))) = c.poll_event() else {
        panic!()
    };
    assert!(r.value.unwrap().same(Value::F32(1.5)));
}

#[test]
fn custom_values_are_set_in_the_extended_protocol_only() {
    let mut config = ClientConfig::new(GCS);
    config.protocol = Protocol::Ext;
    let mut c: Client<1> = Client::new(config, VEHICLE);
    let p = name("CAM_MODE");
    let bytes = Bytes::from_bytes(b"video 4k");
    c.set_custom(p, bytes).unwrap();
    let Some(Message::ParamExtSet(m)) = c.poll_transmit(0) else {
        panic!()
    };
    assert_eq!(
        (m.param_type, m.param_value),
        (MavParamExtType::Custom, bytes)
    );
    let ack = ParamExtAck {
        param_id: p,
        param_value: bytes,
        param_type: MavParamExtType::Custom,
        param_result: ParamAck::Accepted,
    };
    c.handle(5_000, VEHICLE, &Message::ParamExtAck(ack));
    let Some(Event::Set(Some(r))) = c.poll_event() else {
        panic!()
    };
    assert_eq!((r.value, r.custom), (None, Some(bytes)));
    // Our server holds no CUSTOM values: refused, with nothing acknowledged.
    let (mut gcs, mut vehicle) = pair_in(3, Encoding::Bytewise, Protocol::Ext);
    let mut sim = Sim::new(9, Faults::CLEAN);
    let target = vehicle.params[1].name;
    gcs.client.set_custom(target, bytes).unwrap();
    let Event::Set(Some(r)) = run_op(&mut sim, &mut gcs, &mut vehicle) else {
        panic!()
    };
    assert_eq!((r.value, r.custom), (None, None));
    // V1 has no CUSTOM type: over at once.
    let mut v1: Client<1> = Client::new(ClientConfig::new(GCS), VEHICLE);
    v1.set_custom(p, bytes).unwrap();
    assert_eq!(v1.poll_event(), Some(Event::Set(None)));
    assert!(v1.poll_transmit(0).is_none() && v1.is_idle());
}

#[test]
fn a_paced_list_keeps_its_rate_when_polled_late() {
    let params = store(100, 1);
    let mut config = ServerConfig::new(VEHICLE);
    config.list_interval_us = 100;
    let mut server: Server<4> = Server::new(config);
    let mut p = params.clone();
    server.handle(
        &mut p[..],
        0,
        GCS,
        &Message::ParamRequestList(Default::default()),
    );
    let mut drain =
        |now: u64| std::iter::from_fn(|| server.poll_transmit(&params[..], now)).count();
    // One at once, then nothing before the next is due.
    assert_eq!(drain(0), 1);
    assert_eq!(drain(50), 0);
    assert_eq!(drain(100), 1);
    // Polled 1 ms late: what fell due meanwhile, at most LIST_BURST at once.
    assert_eq!(drain(1_100), LIST_BURST as usize);
    // Polled every 300 µs: three a time, 1 every 100 µs on average.
    assert_eq!(drain(1_400), 3);
    assert_eq!(drain(1_700), 3);
}
