//! The command client and server: unit cases, then both sides through a lossy link.

use std::collections::HashMap;

use ferrolink_runtime::mavlink::service::command::{
    Ack, Client, ClientConfig, Command, Event, Form, Request, Server, ServerConfig,
};
use ferrolink_runtime::mavlink::service::messages::{
    CommandAck, CommandLong, MavCmd, MavFrame, MavResult, Message,
};
use ferrolink_runtime::mavlink::service::Address;
use proptest::prelude::*;

use super::lossy::{Faults, LinkStats, Node, Sim};

const GCS: Address = Address::new(255, 190);
const VEHICLE: Address = Address::new(1, 1);

fn client() -> Client<4> {
    Client::new(ClientConfig::new(GCS))
}

fn server() -> Server<4> {
    Server::new(ServerConfig::new(VEHICLE))
}

fn arm() -> Command {
    Command::long(
        MavCmd::ComponentArmDisarm,
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    )
}

fn ack(result: MavResult, progress: u8) -> Message {
    Message::CommandAck(CommandAck {
        command: MavCmd::ComponentArmDisarm,
        result,
        progress,
        result_param2: 0,
        target_system: GCS.system,
        target_component: GCS.component,
    })
}

#[test]
fn retries_count_confirmation_up_then_give_up() {
    let mut c = client();
    c.send(0, VEHICLE, arm()).unwrap();
    let mut confirmations = Vec::new();
    let mut now = 0;
    while let Some(deadline) = c.poll_timeout() {
        now = now.max(deadline);
        while let Some(m) = c.poll_transmit(now) {
            let Message::CommandLong(m) = m else {
                panic!("{m:?}")
            };
            assert_eq!((m.target_system, m.target_component), (1, 1));
            confirmations.push((now, m.confirmation));
        }
    }
    assert_eq!(
        confirmations,
        [(0, 0), (500_000, 1), (1_000_000, 2), (1_500_000, 3)]
    );
    assert_eq!(
        c.poll_event(),
        Some(Event::Done {
            target: VEHICLE,
            command: MavCmd::ComponentArmDisarm,
            ack: None
        })
    );
    assert!(c.is_idle());
}

#[test]
fn an_ack_ends_it_and_only_the_targets_ack_counts() {
    let mut c = client();
    c.send(0, VEHICLE, arm()).unwrap();
    assert!(c.poll_transmit(0).is_some());
    // From another system, or for another command, or for another client: ignored.
    c.handle(10, Address::new(2, 1), &ack(MavResult::Accepted, 0));
    let Message::CommandAck(mut other) = ack(MavResult::Accepted, 0) else {
        unreachable!()
    };
    other.command = MavCmd::NavTakeoff;
    c.handle(10, VEHICLE, &Message::CommandAck(other));
    other.command = MavCmd::ComponentArmDisarm;
    other.target_system = 254;
    c.handle(10, VEHICLE, &Message::CommandAck(other));
    assert_eq!(c.poll_event(), None);
    c.handle(20, VEHICLE, &ack(MavResult::Denied, 3));
    assert_eq!(
        c.poll_event(),
        Some(Event::Done {
            target: VEHICLE,
            command: MavCmd::ComponentArmDisarm,
            ack: Some(Ack {
                result: MavResult::Denied,
                progress: 3,
                result_param2: 0
            })
        })
    );
    assert_eq!(c.poll_transmit(10_000_000), None);
}

#[test]
fn in_progress_stops_retries_and_stretches_the_wait() {
    let mut c = client();
    c.send(0, VEHICLE, arm()).unwrap();
    c.poll_transmit(0).unwrap();
    c.handle(100_000, VEHICLE, &ack(MavResult::InProgress, 10));
    assert_eq!(
        c.poll_event(),
        Some(Event::Progress {
            target: VEHICLE,
            command: MavCmd::ComponentArmDisarm,
            progress: 10
        })
    );
    // No retry at 0.5 s: the target is working on it.
    assert_eq!(c.poll_timeout(), Some(3_100_000));
    assert_eq!(c.poll_transmit(600_000), None);
    c.handle(3_000_000, VEHICLE, &ack(MavResult::InProgress, 60));
    assert_eq!(c.poll_transmit(3_500_000), None);
    assert!(matches!(
        c.poll_event(),
        Some(Event::Progress { progress: 60, .. })
    ));
    c.handle(4_000_000, VEHICLE, &ack(MavResult::Accepted, 0));
    assert!(matches!(
        c.poll_event(),
        Some(Event::Done {
            ack: Some(Ack {
                result: MavResult::Accepted,
                ..
            }),
            ..
        })
    ));
}

#[test]
fn silence_after_in_progress_is_no_answer() {
    let mut c = client();
    c.send(0, VEHICLE, arm()).unwrap();
    c.poll_transmit(0).unwrap();
    c.handle(100, VEHICLE, &ack(MavResult::InProgress, 255));
    c.poll_event();
    assert_eq!(c.poll_transmit(3_000_100), None);
    assert!(matches!(
        c.poll_event(),
        Some(Event::Done { ack: None, .. })
    ));
}

#[test]
fn long_only_and_int_only_switch_the_form_once() {
    let mut c = client();
    let takeoff = Command::int(
        MavCmd::NavTakeoff,
        MavFrame::GlobalRelativeAlt,
        [0.0; 4],
        47.397_742_1,
        8.545_594_3,
        10.0,
    );
    c.send(0, VEHICLE, takeoff).unwrap();
    let Some(Message::CommandInt(first)) = c.poll_transmit(0) else {
        panic!()
    };
    assert_eq!((first.x, first.y), (473_977_421, 85_455_943));
    let only = |result| {
        let Message::CommandAck(mut a) = ack(result, 0) else {
            unreachable!()
        };
        a.command = MavCmd::NavTakeoff;
        Message::CommandAck(a)
    };
    c.handle(10, VEHICLE, &only(MavResult::CommandLongOnly));
    let Some(Message::CommandLong(second)) = c.poll_transmit(10) else {
        panic!()
    };
    assert_eq!((second.confirmation, second.param7), (0, 10.0));
    // Asked back: no ping-pong, the answer stands.
    c.handle(20, VEHICLE, &only(MavResult::CommandIntOnly));
    assert!(matches!(
        c.poll_event(),
        Some(Event::Done {
            ack: Some(Ack {
                result: MavResult::CommandIntOnly,
                ..
            }),
            ..
        })
    ));
}

#[test]
fn cancel_sends_command_cancel_and_waits_for_the_final_ack() {
    let mut c = client();
    c.send(0, VEHICLE, arm()).unwrap();
    c.poll_transmit(0).unwrap();
    c.handle(10, VEHICLE, &ack(MavResult::InProgress, 5));
    assert!(c.cancel(VEHICLE, MavCmd::ComponentArmDisarm));
    let Some(Message::CommandCancel(m)) = c.poll_transmit(20) else {
        panic!()
    };
    assert_eq!(
        (m.target_system, m.command),
        (1, MavCmd::ComponentArmDisarm)
    );
    c.handle(30, VEHICLE, &ack(MavResult::Cancelled, 0));
    c.poll_event();
    assert!(matches!(
        c.poll_event(),
        Some(Event::Done {
            ack: Some(Ack {
                result: MavResult::Cancelled,
                ..
            }),
            ..
        })
    ));
}

#[test]
fn one_of_each_command_per_target_at_a_time() {
    let mut c = client();
    c.send(0, VEHICLE, arm()).unwrap();
    assert!(c.send(0, VEHICLE, arm()).is_err());
    c.send(0, Address::new(2, 1), arm()).unwrap();
}

fn long(confirmation: u8, p1: f32) -> Message {
    Message::CommandLong(CommandLong {
        target_system: 1,
        target_component: 1,
        command: MavCmd::ComponentArmDisarm,
        confirmation,
        param1: p1,
        ..Default::default()
    })
}

#[test]
fn the_server_runs_a_command_once_and_answers_retries_alike() {
    let mut s = server();
    let run = s.handle(0, GCS, &long(0, 1.0));
    assert!(matches!(run, Some(Request::Run { from: GCS, .. })));
    // A retry while it runs: IN_PROGRESS, not a second run.
    assert_eq!(s.handle(10, GCS, &long(1, 1.0)), None);
    let Some(Message::CommandAck(a)) = s.poll_transmit(10) else {
        panic!()
    };
    assert_eq!(a.result, MavResult::InProgress);
    assert!(s.respond(
        20,
        GCS,
        MavCmd::ComponentArmDisarm,
        Ack::new(MavResult::Accepted)
    ));
    let Some(Message::CommandAck(a)) = s.poll_transmit(20) else {
        panic!()
    };
    assert_eq!(
        (a.result, a.target_system, a.target_component),
        (MavResult::Accepted, 255, 190)
    );
    // A retry of the answered command (its ACK was lost): the same answer again, at any time.
    assert_eq!(s.handle(10_000_000, GCS, &long(2, 1.0)), None);
    let Some(Message::CommandAck(a)) = s.poll_transmit(10_000_000) else {
        panic!()
    };
    assert_eq!(a.result, MavResult::Accepted);
    // A new command (confirmation 0) later, or with other values: runs.
    assert!(s.handle(20_000_000, GCS, &long(0, 1.0)).is_some());
    s.respond(
        20_000_001,
        GCS,
        MavCmd::ComponentArmDisarm,
        Ack::new(MavResult::Accepted),
    );
    assert!(s.handle(20_000_002, GCS, &long(0, 0.0)).is_some());
    // Not for us: ignored.
    let Message::CommandLong(mut other) = long(0, 1.0) else {
        unreachable!()
    };
    other.target_system = 7;
    assert_eq!(s.handle(0, GCS, &Message::CommandLong(other)), None);
}

#[test]
fn a_repeated_copy_within_the_window_does_not_run_again() {
    let mut s = server();
    assert!(s.handle(0, GCS, &long(0, 1.0)).is_some());
    s.respond(
        1,
        GCS,
        MavCmd::ComponentArmDisarm,
        Ack::new(MavResult::Accepted),
    );
    s.poll_transmit(1);
    assert_eq!(s.handle(1_000_000, GCS, &long(0, 1.0)), None);
    assert!(s.poll_transmit(1_000_000).is_some());
}

#[test]
fn a_full_server_refuses_for_now() {
    let mut s: Server<1> = Server::new(ServerConfig::new(VEHICLE));
    assert!(s.handle(0, GCS, &long(0, 1.0)).is_some());
    // The one slot runs; another sender's command is refused, not forgotten silently.
    assert_eq!(s.handle(1, Address::new(254, 1), &long(0, 1.0)), None);
    let Some(Message::CommandAck(a)) = s.poll_transmit(1) else {
        panic!()
    };
    assert_eq!(
        (a.result, a.target_system),
        (MavResult::TemporarilyRejected, 254)
    );
}

/// A ground station sending a list of commands, one after another.
struct Gcs {
    client: Client<4>,
    next: usize,
    count: usize,
    results: Vec<Option<Ack>>,
    progress: Vec<u8>,
}

impl Node for Gcs {
    fn address(&self) -> Address {
        GCS
    }
    fn handle(&mut self, now: u64, from: Address, msg: &Message) {
        self.client.handle(now, from, msg);
        self.drain(now);
    }
    fn poll_transmit(&mut self, now: u64) -> Option<Message> {
        let m = self.client.poll_transmit(now);
        self.drain(now);
        m.or_else(|| self.client.poll_transmit(now))
    }
    fn poll_timeout(&self) -> Option<u64> {
        self.client.poll_timeout()
    }
}

impl Gcs {
    fn new(count: usize) -> Self {
        // Ten retries, as on a long-range radio: a command fails only if eleven round trips in
        // a row do.
        let mut config = ClientConfig::new(GCS);
        config.retry.retries = 10;
        Self {
            client: Client::new(config),
            next: 0,
            count,
            results: Vec::new(),
            progress: Vec::new(),
        }
    }
    fn drain(&mut self, now: u64) {
        while let Some(e) = self.client.poll_event() {
            match e {
                Event::Progress { progress, .. } => self.progress.push(progress),
                Event::Done { ack, .. } => self.results.push(ack),
            }
        }
        if self.client.is_idle() && self.next < self.count {
            // Command i carries i in param2; odd ones go as COMMAND_INT. Four ids in turn: an
            // ACK names only the command id, so a late copy of the last ACK for one id must not
            // meet the next command of that id (three exchanges outlast the link's delay).
            let id = [MavCmd::User1, MavCmd::User2, MavCmd::User3, MavCmd::User4][self.next % 4];
            let mut c = Command::long(id, [0.0, self.next as f32, 0.0, 0.0, 0.0, 0.0, 0.0]);
            if self.next % 2 == 1 {
                c.form = Form::Int;
            }
            self.client.send(now, VEHICLE, c).unwrap();
            self.next += 1;
        }
    }
}

/// A vehicle that runs each command; every third takes 2 s, reporting progress twice.
struct Vehicle {
    server: Server<4>,
    runs: HashMap<u32, u32>,
    running: Vec<(u64, Address, MavCmd, u8)>,
}

impl Node for Vehicle {
    fn address(&self) -> Address {
        VEHICLE
    }
    fn handle(&mut self, now: u64, from: Address, msg: &Message) {
        if let Some(Request::Run { from, command }) = self.server.handle(now, from, msg) {
            let i = command.params[1] as u32;
            *self.runs.entry(i).or_default() += 1;
            if i.is_multiple_of(3) {
                self.server.respond(
                    now,
                    from,
                    command.command,
                    Ack {
                        result: MavResult::InProgress,
                        progress: 0,
                        result_param2: 0,
                    },
                );
                self.running
                    .push((now + 1_000_000, from, command.command, 50));
            } else {
                self.server
                    .respond(now, from, command.command, Ack::new(MavResult::Accepted));
            }
        }
    }
    fn poll_transmit(&mut self, now: u64) -> Option<Message> {
        let mut later = Vec::new();
        for (at, from, cmd, progress) in self.running.drain(..) {
            if now < at {
                later.push((at, from, cmd, progress));
            } else if progress < 100 {
                self.server.respond(
                    now,
                    from,
                    cmd,
                    Ack {
                        result: MavResult::InProgress,
                        progress,
                        result_param2: 0,
                    },
                );
                later.push((at + 1_000_000, from, cmd, progress + 50));
            } else {
                self.server
                    .respond(now, from, cmd, Ack::new(MavResult::Accepted));
            }
        }
        self.running = later;
        self.server.poll_transmit(now)
    }
    fn poll_timeout(&self) -> Option<u64> {
        self.running.iter().map(|r| r.0).min()
    }
}

fn exchange(seed: u64, faults: Faults, count: usize) -> (Gcs, Vehicle, LinkStats) {
    let mut sim = Sim::new(seed, faults);
    let mut gcs = Gcs::new(count);
    // The window covers the clients' whole retry span (eleven tries, 0.5 s apart).
    let mut config = ServerConfig::new(VEHICLE);
    config.repeat_window_us = 6_000_000;
    let mut vehicle = Vehicle {
        server: Server::new(config),
        runs: HashMap::new(),
        running: Vec::new(),
    };
    let ended = sim.run(&mut gcs, &mut vehicle, 3_600_000_000, |g, _| {
        g.results.len() == count
    });
    assert!(ended, "the client never finished");
    (gcs, vehicle, sim.stats)
}

#[test]
fn on_a_clean_link_every_command_runs_once_and_is_accepted() {
    let (gcs, vehicle, stats) = exchange(1, Faults::CLEAN, 30);
    assert_eq!(stats.lost, 0);
    assert!(gcs
        .results
        .iter()
        .all(|r| r.is_some_and(|a| a.result == MavResult::Accepted)));
    assert!(vehicle.runs.values().all(|&n| n == 1));
    assert_eq!(vehicle.runs.len(), 30);
    assert!(gcs.progress.contains(&50));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Through a link that loses 20 %, repeats 5 % and reorders: no command runs twice, and
    /// an answer the client reports is the one the vehicle gave.
    #[test]
    fn on_a_bad_radio_nothing_runs_twice(seed in any::<u64>()) {
        let (gcs, vehicle, stats) = exchange(seed, Faults::BAD_RADIO, 30);
        prop_assert!(stats.lost > 0, "{:?}", stats);
        for (&i, &n) in &vehicle.runs {
            prop_assert_eq!(n, 1, "command {} ran {} times", i, n);
        }
        // An accepted command ran; a refused one (sent while the last of its id still ran,
        // after its client gave up on it) did not.
        for (i, r) in gcs.results.iter().enumerate() {
            let runs = vehicle.runs.get(&(i as u32)).copied().unwrap_or(0);
            match r.map(|a| a.result) {
                Some(MavResult::Accepted) => prop_assert_eq!(runs, 1, "command {}", i),
                Some(MavResult::TemporarilyRejected) => prop_assert_eq!(runs, 0, "command {}", i),
                other => prop_assert!(other.is_none(), "command {}: {:?}", i, other),
            }
        }
        // Eleven tries each: short commands get through. (A long one whose final ACK is lost
        // ends without an answer: after IN_PROGRESS the protocol asks for no retries.)
        let answered = gcs
            .results
            .iter()
            .enumerate()
            .filter(|(i, r)| i % 3 != 0 && r.is_some_and(|a| a.result == MavResult::Accepted))
            .count();
        prop_assert!(answered >= 19, "only {} of 20 short commands answered", answered);
    }
}

/// A command refused, another, then the first again: the first is run again (take off while
/// disarmed is refused; arm; take off), not answered from memory as a copy. An accepted one
/// sent again at once is still a copy.
#[test]
fn the_same_command_after_another_is_a_new_one() {
    let mut s = server();
    let takeoff = Message::CommandLong(CommandLong {
        command: MavCmd::NavTakeoff,
        target_system: 1,
        target_component: 1,
        ..Default::default()
    });
    assert!(s.handle(0, GCS, &takeoff).is_some());
    s.respond(
        1,
        GCS,
        MavCmd::NavTakeoff,
        Ack::new(MavResult::TemporarilyRejected),
    );
    s.poll_transmit(1);
    assert!(s.handle(100, GCS, &long(0, 1.0)).is_some());
    s.respond(
        101,
        GCS,
        MavCmd::ComponentArmDisarm,
        Ack::new(MavResult::Accepted),
    );
    s.poll_transmit(101);
    assert!(s.handle(200, GCS, &takeoff).is_some(), "run again");
    // A copy of it right after is still a copy.
    s.respond(201, GCS, MavCmd::NavTakeoff, Ack::new(MavResult::Accepted));
    s.poll_transmit(201);
    assert_eq!(s.handle(300, GCS, &takeoff), None);
}
