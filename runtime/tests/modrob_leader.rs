//! ModRob-1 leader and piecewise reassembly: a two-network robot table, modules appearing,
//! unknown and restarted modules, every routing rule, reassembly in every order and with
//! every chunk lost, and property tests shared with the `modrob_decoders` fuzz target.

use ferrolink_runtime::modrob::dictionary::{Instance, Network, Robot, Transport};
use ferrolink_runtime::modrob::leader::{
    Config, Forward, Leader, LeaderError, Observed, Outgoing, Port,
};
use ferrolink_runtime::modrob::piecewise::{Lost, Progress, Reassembler, Sender};
use ferrolink_runtime::modrob::{CommandKind, Message};
use proptest::prelude::*;

#[path = "scripts/modrob_decoders.rs"]
mod scripts;

const BODY: usize = 0;
const SENSORS: usize = 1;

const LEADER: u16 = 0x01;
const DRIVE_LEFT: u16 = 0x10;
const DRIVE_RIGHT: u16 = 0x11;
const SONAR: u16 = 0x20;
const BUMPER: u16 = 0x21;
/// A module of the parent's network.
const PARENT_PLANNER: u16 = 0x80;

const fn set_value(module: u16, variable: u8, value: f32) -> Message {
    Message::Command {
        module,
        variable,
        command: CommandKind::SetValue(value),
    }
}

const fn set_rate(module: u16, variable: u8, hz: f32) -> Message {
    Message::Command {
        module,
        variable,
        command: CommandKind::SetFrequency(hz),
    }
}

const fn subscribe(module: u16, variable: u8, to: u16, to_variable: u8) -> Message {
    Message::Command {
        module,
        variable,
        command: CommandKind::SetSubscription {
            module: to,
            variable: to_variable,
        },
    }
}

const NETWORKS: &[Network] = &[
    Network {
        name: "body",
        transport: Transport::Can,
        bitrate: 1_000_000,
    },
    Network {
        name: "sensors",
        transport: Transport::Can,
        bitrate: 500_000,
    },
];

/// Drive left: slows down on the sonar's distance (sensors), follows the parent's planner
/// set point (upstream).
const DRIVE_LEFT_COMMANDS: &[Message] = &[
    set_value(DRIVE_LEFT, 0, 0.0),
    set_value(DRIVE_LEFT, 5, 2.5),
    set_rate(DRIVE_LEFT, 1, 100.0),
    subscribe(DRIVE_LEFT, 6, SONAR, 0),
    subscribe(DRIVE_LEFT, 0, PARENT_PLANNER, 3),
];
/// Drive right: follows drive left's speed, on its own network.
const DRIVE_RIGHT_COMMANDS: &[Message] = &[
    set_rate(DRIVE_RIGHT, 1, 100.0),
    subscribe(DRIVE_RIGHT, 0, DRIVE_LEFT, 1),
];
const SONAR_COMMANDS: &[Message] = &[set_value(SONAR, 2, 1.0), set_rate(SONAR, 0, 20.0)];
/// Bumper: watches drive right's speed (body), across networks.
const BUMPER_COMMANDS: &[Message] = &[
    set_rate(BUMPER, 0, 100.0),
    subscribe(BUMPER, 4, DRIVE_RIGHT, 1),
];
/// The leader itself watches the bumper.
const LEADER_COMMANDS: &[Message] = &[subscribe(LEADER, 9, BUMPER, 0)];

const fn instance(
    name: &'static str,
    module: u16,
    network: usize,
    commands: &'static [Message],
) -> Instance {
    Instance {
        name,
        dictionary: name,
        module,
        uuid: None,
        network,
        commands,
    }
}

const INSTANCES: &[Instance] = &[
    instance("leader", LEADER, BODY, LEADER_COMMANDS),
    instance("drive_left", DRIVE_LEFT, BODY, DRIVE_LEFT_COMMANDS),
    instance("drive_right", DRIVE_RIGHT, BODY, DRIVE_RIGHT_COMMANDS),
    instance("sonar", SONAR, SENSORS, SONAR_COMMANDS),
    instance("bumper", BUMPER, SENSORS, BUMPER_COMMANDS),
];

static ROBOT: Robot = Robot {
    name: "cart",
    networks: NETWORKS,
    instances: INSTANCES,
    leader: 0,
};

const UNPACED: Config = Config {
    spacing_us: 0,
    reconfigure_on_announce: true,
};

fn leader() -> Leader<'static, 5> {
    Leader::with_config(&ROBOT, UNPACED).unwrap()
}

fn publication(module: u16, variable: u8) -> Message {
    Message::Publication {
        module,
        variable,
        value: 0.25,
    }
}

fn chunk(module: u16, chunk: u8, chunks: u8) -> Message {
    Message::Piecewise {
        module,
        chunk,
        chunks,
        data: *b"module\0",
    }
}

fn drain(leader: &mut Leader<'static, 5>, now_us: u64) -> Vec<Outgoing> {
    core::iter::from_fn(|| leader.poll(now_us)).collect()
}

fn commands_of(sent: &[Outgoing]) -> Vec<Message> {
    sent.iter().map(|o| o.message).collect()
}

fn forward(upstream: bool, networks: &[usize], local: bool) -> Forward {
    Forward {
        upstream,
        networks: networks.iter().fold(0, |m, n| m | 1 << n),
        local,
    }
}

#[test]
fn nothing_is_sent_before_modules_appear() {
    let mut leader = leader();
    assert!(leader.poll(0).is_none());
    assert_eq!(leader.pending(), 0);
    assert_eq!(leader.module(), LEADER);
    assert_eq!(leader.own_commands(), LEADER_COMMANDS);
    let own = leader.status(0).unwrap();
    assert!(own.present && own.configured);
    for index in 1..INSTANCES.len() {
        let status = leader.status(index).unwrap();
        assert!(!status.present && !status.configured && status.pending == 0);
    }
    assert_eq!(leader.status(5), None);
}

#[test]
fn an_appearing_module_gets_exactly_its_commands_in_order_on_its_network() {
    for (index, instance) in INSTANCES.iter().enumerate().skip(1) {
        let mut leader = leader();
        let hello = publication(instance.module, 1);
        assert_eq!(
            leader.observe(instance.network, &hello),
            Observed::New { instance: index }
        );
        assert_eq!(leader.pending(), instance.commands.len());
        let sent = drain(&mut leader, 0);
        assert_eq!(commands_of(&sent), instance.commands);
        assert!(sent
            .iter()
            .all(|o| o.network == instance.network && o.instance == index));
        let status = leader.status(index).unwrap();
        assert!(status.present && status.configured);
        assert_eq!(status.configurations, 1);
        // Seen again: nothing more.
        assert_eq!(
            leader.observe(instance.network, &hello),
            Observed::Known { instance: index }
        );
        assert!(leader.poll(1).is_none());
        let stats = leader.stats();
        assert_eq!(stats.appeared, 1);
        assert_eq!(stats.configured, 1);
        assert_eq!(stats.commands_sent, instance.commands.len() as u64);
    }
}

#[test]
fn modules_on_both_networks_each_get_theirs() {
    let mut leader = leader();
    let _ = leader.receive(Port::Network(SENSORS), &chunk(BUMPER, 0, 3));
    let _ = leader.receive(Port::Network(BODY), &publication(DRIVE_LEFT, 1));
    let sent = drain(&mut leader, 0);
    let on = |network: usize| -> Vec<Message> {
        sent.iter()
            .filter(|o| o.network == network)
            .map(|o| o.message)
            .collect()
    };
    assert_eq!(on(SENSORS), BUMPER_COMMANDS);
    assert_eq!(on(BODY), DRIVE_LEFT_COMMANDS);
    assert_eq!(leader.stats().appeared, 2);
}

#[test]
fn pacing_spaces_commands_per_network() {
    let mut leader = Leader::<5>::new(&ROBOT).unwrap();
    assert_eq!(leader.config().spacing_us, 500);
    let _ = leader.observe(BODY, &publication(DRIVE_LEFT, 1));
    let _ = leader.observe(SENSORS, &publication(SONAR, 0));
    // One command per network at t = 0, then each network waits 500 µs.
    let first = drain(&mut leader, 0);
    assert_eq!(
        first
            .iter()
            .map(|o| (o.network, o.message))
            .collect::<Vec<_>>(),
        [(BODY, DRIVE_LEFT_COMMANDS[0]), (SENSORS, SONAR_COMMANDS[0])]
    );
    assert!(leader.poll(499).is_none());
    let mut body = vec![DRIVE_LEFT_COMMANDS[0]];
    let mut sensors = vec![SONAR_COMMANDS[0]];
    let mut now = 500;
    while leader.pending() > 0 {
        for out in drain(&mut leader, now) {
            match out.network {
                BODY => body.push(out.message),
                _ => sensors.push(out.message),
            }
        }
        now += 500;
    }
    assert_eq!(body, DRIVE_LEFT_COMMANDS);
    assert_eq!(sensors, SONAR_COMMANDS);
    assert_eq!(now, 500 * DRIVE_LEFT_COMMANDS.len() as u64);
}

#[test]
fn an_unknown_module_gets_nothing_and_is_counted() {
    let mut leader = leader();
    assert_eq!(
        leader.observe(SENSORS, &publication(0x42, 0)),
        Observed::Unknown {
            module: 0x42,
            first: true
        }
    );
    assert_eq!(
        leader.observe(SENSORS, &chunk(0x42, 0, 2)),
        Observed::Unknown {
            module: 0x42,
            first: false
        }
    );
    // The same MI on the other network is another module.
    assert_eq!(
        leader.observe(BODY, &publication(0x42, 0)),
        Observed::Unknown {
            module: 0x42,
            first: true
        }
    );
    assert!(leader.poll(0).is_none());
    assert_eq!(leader.stats().unknown_modules, 2);
    assert_eq!(
        leader.unknown_modules().collect::<Vec<_>>(),
        [(0x42, SENSORS), (0x42, BODY)]
    );
}

#[test]
fn unknown_modules_beyond_the_slots_are_counted() {
    let mut leader = Leader::<5, 2>::with_config(&ROBOT, UNPACED).unwrap();
    for module in 0x40..0x45 {
        let _ = leader.observe(BODY, &publication(module, 0));
    }
    assert_eq!(leader.stats().unknown_modules, 2);
    assert_eq!(leader.stats().unknown_unrecorded, 3);
    assert!(leader.poll(0).is_none());
}

#[test]
fn a_restart_announcement_reconfigures() {
    let mut leader = leader();
    // Chunk 0 as the first message is an appearance, not a restart.
    assert_eq!(
        leader.observe(SENSORS, &chunk(SONAR, 0, 2)),
        Observed::New { instance: 3 }
    );
    assert_eq!(commands_of(&drain(&mut leader, 0)), SONAR_COMMANDS);
    // The rest of the text and publications change nothing.
    assert_eq!(
        leader.observe(SENSORS, &chunk(SONAR, 1, 2)),
        Observed::Known { instance: 3 }
    );
    assert!(leader.poll(0).is_none());
    // Power cycled: it announces itself again.
    assert_eq!(
        leader.observe(SENSORS, &chunk(SONAR, 0, 2)),
        Observed::Restarted { instance: 3 }
    );
    assert_eq!(commands_of(&drain(&mut leader, 0)), SONAR_COMMANDS);
    let stats = leader.stats();
    assert_eq!(
        (stats.appeared, stats.restarted, stats.configured),
        (1, 1, 2)
    );
    assert_eq!(leader.status(3).unwrap().configurations, 2);
}

#[test]
fn a_restart_while_being_configured_starts_over() {
    let mut leader = leader();
    let _ = leader.observe(BODY, &chunk(DRIVE_LEFT, 0, 1));
    let first = leader.poll(0).unwrap();
    let _ = leader.poll(0).unwrap();
    // The power-up announcement was the first chunk 0; a second one is a restart.
    let _ = leader.observe(BODY, &chunk(DRIVE_LEFT, 0, 1));
    let rest = drain(&mut leader, 0);
    assert_eq!(rest[0], first);
    assert_eq!(commands_of(&rest), DRIVE_LEFT_COMMANDS);
    assert_eq!(leader.status(1).unwrap().configurations, 1);
}

#[test]
fn announcements_can_be_taken_as_plain_traffic() {
    let mut leader = Leader::<5>::with_config(
        &ROBOT,
        Config {
            reconfigure_on_announce: false,
            ..UNPACED
        },
    )
    .unwrap();
    let _ = leader.observe(SENSORS, &chunk(SONAR, 0, 2));
    let _ = drain(&mut leader, 0);
    assert_eq!(
        leader.observe(SENSORS, &chunk(SONAR, 0, 2)),
        Observed::Known { instance: 3 }
    );
    assert!(leader.poll(0).is_none());
}

#[test]
fn manual_reconfiguration() {
    let mut leader = leader();
    assert!(!leader.reconfigure(3), "not present yet");
    assert!(!leader.reconfigure(0), "the leader configures itself");
    let _ = leader.observe(SENSORS, &publication(SONAR, 0));
    let _ = drain(&mut leader, 0);
    assert!(leader.reconfigure(3));
    assert_eq!(commands_of(&drain(&mut leader, 0)), SONAR_COMMANDS);
}

#[test]
fn a_module_on_the_wrong_network_is_not_configured() {
    let mut leader = leader();
    assert_eq!(
        leader.observe(BODY, &publication(SONAR, 0)),
        Observed::WrongNetwork { instance: 3 }
    );
    assert!(leader.poll(0).is_none());
    assert!(!leader.status(3).unwrap().present);
    assert_eq!(leader.stats().wrong_network, 1);
}

#[test]
fn commands_echoes_and_other_networks_are_not_observed() {
    let mut leader = leader();
    assert_eq!(
        leader.observe(BODY, &set_value(DRIVE_LEFT, 0, 1.0)),
        Observed::Ignored
    );
    assert_eq!(leader.observe(BODY, &publication(LEADER, 0)), Observed::Own);
    assert_eq!(
        leader.observe(7, &publication(DRIVE_LEFT, 0)),
        Observed::Ignored
    );
    assert!(leader.poll(0).is_none());
}

#[test]
fn bad_tables_are_refused() {
    assert_eq!(
        Leader::<4>::new(&ROBOT).err(),
        Some(LeaderError::TooManyInstances {
            instances: 5,
            capacity: 4
        })
    );
    const MISPLACED: &[Instance] = &[instance("leader", LEADER, 2, &[])];
    static BAD: Robot = Robot {
        name: "bad",
        networks: NETWORKS,
        instances: MISPLACED,
        leader: 0,
    };
    assert_eq!(
        Leader::<1>::new(&BAD).err(),
        Some(LeaderError::NoSuchNetwork {
            instance: 0,
            network: 2
        })
    );
}

// Routing, rule by rule.

#[test]
fn downstream_publications_go_upstream_and_to_subscribing_networks() {
    let mut leader = leader();
    // Nobody elsewhere subscribes to drive left's VI 2: upstream only.
    assert_eq!(
        leader.route(Port::Network(BODY), &publication(DRIVE_LEFT, 2)),
        forward(true, &[], false)
    );
    // Drive right (body) subscribes to drive left's VI 1: same network, not sent back.
    assert_eq!(
        leader.route(Port::Network(BODY), &publication(DRIVE_LEFT, 1)),
        forward(true, &[], false)
    );
    // The bumper (sensors) subscribes to drive right's VI 1.
    assert_eq!(
        leader.route(Port::Network(BODY), &publication(DRIVE_RIGHT, 1)),
        forward(true, &[SENSORS], false)
    );
    // Drive left (body) subscribes to the sonar's VI 0.
    assert_eq!(
        leader.route(Port::Network(SENSORS), &publication(SONAR, 0)),
        forward(true, &[BODY], false)
    );
    // The leader subscribes to the bumper's VI 0.
    assert_eq!(
        leader.route(Port::Network(SENSORS), &publication(BUMPER, 0)),
        forward(true, &[], true)
    );
    let stats = leader.stats().route;
    assert_eq!(
        (
            stats.upstream,
            stats.across,
            stats.local,
            stats.dropped_from_downstream
        ),
        (5, 2, 1, 0)
    );
}

#[test]
fn piecewise_chunks_go_upstream_only() {
    let mut leader = leader();
    assert_eq!(
        leader.route(Port::Network(SENSORS), &chunk(SONAR, 0, 2)),
        forward(true, &[], false)
    );
    assert_eq!(
        leader.route(Port::Network(BODY), &chunk(0x55, 1, 2)),
        forward(true, &[], false)
    );
    assert!(leader
        .route(Port::Upstream, &chunk(PARENT_PLANNER, 0, 1))
        .is_empty());
}

#[test]
fn upstream_commands_go_to_the_addressed_modules_network() {
    let mut leader = leader();
    assert_eq!(
        leader.route(Port::Upstream, &set_value(SONAR, 2, 0.5)),
        forward(false, &[SENSORS], false)
    );
    assert_eq!(
        leader.route(Port::Upstream, &set_rate(DRIVE_RIGHT, 1, 50.0)),
        forward(false, &[BODY], false)
    );
    // To the leader itself.
    assert_eq!(
        leader.route(Port::Upstream, &set_value(LEADER, 0, 1.0)),
        forward(false, &[], true)
    );
    // To a module nobody knows: dropped.
    assert!(leader
        .route(Port::Upstream, &set_value(0x66, 0, 1.0))
        .is_empty());
    // Once seen on the sensors network, it is reachable there.
    let _ = leader.receive(Port::Network(SENSORS), &publication(0x66, 0));
    assert_eq!(
        leader.route(Port::Upstream, &set_value(0x66, 0, 1.0)),
        forward(false, &[SENSORS], false)
    );
    let stats = leader.stats().route;
    assert_eq!(
        (stats.downstream, stats.local, stats.dropped_from_upstream),
        (3, 1, 1)
    );
}

#[test]
fn upstream_publications_go_only_where_subscribed() {
    let mut leader = leader();
    // Drive left (body) subscribes to the planner's VI 3.
    assert_eq!(
        leader.route(Port::Upstream, &publication(PARENT_PLANNER, 3)),
        forward(false, &[BODY], false)
    );
    // Nobody subscribes to VI 4.
    assert!(leader
        .route(Port::Upstream, &publication(PARENT_PLANNER, 4))
        .is_empty());
    // The sonar's own publication coming back down from the parent: dropped, though drive
    // left subscribes to it (it already got it across).
    assert!(leader
        .route(Port::Upstream, &publication(SONAR, 0))
        .is_empty());
    assert_eq!(leader.stats().route.dropped_from_upstream, 2);
}

#[test]
fn downstream_commands_cross_or_go_upstream() {
    let mut leader = leader();
    // A body module commanding the bumper: across to sensors.
    assert_eq!(
        leader.route(Port::Network(BODY), &set_value(BUMPER, 0, 1.0)),
        forward(false, &[SENSORS], false)
    );
    // Commanding a module of its own network: already delivered.
    assert!(leader
        .route(Port::Network(BODY), &set_value(DRIVE_RIGHT, 0, 1.0))
        .is_empty());
    // Commanding the leader.
    assert_eq!(
        leader.route(Port::Network(SENSORS), &set_value(LEADER, 0, 1.0)),
        forward(false, &[], true)
    );
    // Commanding a module this robot does not know: the default route, upstream.
    assert_eq!(
        leader.route(Port::Network(SENSORS), &set_value(PARENT_PLANNER, 0, 1.0)),
        forward(true, &[], false)
    );
    assert_eq!(leader.stats().route.dropped_from_downstream, 1);
}

#[test]
fn nothing_goes_back_where_it_came_from() {
    let mut leader = leader();
    let _ = leader.receive(Port::Network(BODY), &publication(0x70, 0));
    let _ = leader.receive(Port::Network(SENSORS), &publication(0x70, 0));
    let messages = [
        publication(DRIVE_LEFT, 1),
        publication(DRIVE_RIGHT, 1),
        publication(SONAR, 0),
        publication(BUMPER, 0),
        publication(0x70, 0),
        publication(PARENT_PLANNER, 3),
        chunk(SONAR, 0, 1),
        set_value(DRIVE_LEFT, 0, 1.0),
        set_value(SONAR, 0, 1.0),
        set_value(0x70, 0, 1.0),
        set_value(PARENT_PLANNER, 0, 1.0),
    ];
    for message in &messages {
        for network in [BODY, SENSORS] {
            let f = leader.route(Port::Network(network), message);
            assert!(!f.to_network(network), "{message:?} from {network}");
        }
    }
    // A command to a module seen on both networks goes to the other one only.
    assert_eq!(
        leader.route(Port::Network(BODY), &set_value(0x70, 0, 1.0)),
        forward(false, &[SENSORS], false)
    );
}

#[test]
fn echoes_of_the_leader_and_unknown_networks_are_dropped() {
    let mut leader = leader();
    assert!(leader
        .route(Port::Network(BODY), &publication(LEADER, 0))
        .is_empty());
    assert!(leader
        .route(Port::Network(SENSORS), &chunk(LEADER, 0, 1))
        .is_empty());
    assert!(leader
        .route(Port::Network(9), &publication(SONAR, 0))
        .is_empty());
    assert_eq!(leader.stats().route.dropped_from_downstream, 3);
}

// Piecewise reassembly.

const TEXT: &[u8] = b"sonar, front, 0.2..4 m, 20 Hz"; // 29 bytes: 5 chunks

fn chunks_of(module: u16, text: &[u8]) -> Vec<Message> {
    let mut sender = Sender::new(module, text);
    sender.restart();
    core::iter::from_fn(|| sender.next_chunk()).collect()
}

fn permutations(items: &[usize]) -> Vec<Vec<usize>> {
    if items.len() <= 1 {
        return vec![items.to_vec()];
    }
    let mut all = Vec::new();
    for (i, &first) in items.iter().enumerate() {
        let mut rest = items.to_vec();
        rest.remove(i);
        for mut tail in permutations(&rest) {
            tail.insert(0, first);
            all.push(tail);
        }
    }
    all
}

#[test]
fn reassembly_in_order() {
    let parts = chunks_of(SONAR, TEXT);
    assert_eq!(parts.len(), 5);
    let mut r = Reassembler::<64>::new(SONAR);
    for (i, part) in parts.iter().enumerate() {
        let out = r.push_message(part);
        assert!(!out.reordered && out.lost.is_none());
        if i < 4 {
            assert_eq!(
                out.progress,
                Progress::Pending {
                    received: i as u16 + 1,
                    chunks: 5
                }
            );
            assert_eq!(r.missing_count(), 4 - i as u16);
        } else {
            assert_eq!(out.complete(), Some(TEXT));
        }
    }
    assert_eq!(r.stats().completed, 1);
    assert_eq!(r.stats().reordered, 0);
}

#[test]
fn every_order_of_four_chunks_reassembles() {
    let text = b"bumper, rear left, 1 byte"; // 25 bytes: 3 full chunks and a padded one
    let parts = chunks_of(BUMPER, text);
    assert_eq!(parts.len(), 4);
    let orders = permutations(&[0, 1, 2, 3]);
    assert_eq!(orders.len(), 24);
    for order in orders {
        let mut r = Reassembler::<32>::new(BUMPER);
        let mut reordered = 0;
        for (step, &index) in order.iter().enumerate() {
            let out = r.push_message(&parts[index]);
            assert!(out.lost.is_none());
            let expected = order[..step].iter().any(|&earlier| earlier > index);
            assert_eq!(out.reordered, expected, "{order:?}");
            reordered += u32::from(expected);
            if step < 3 {
                assert!(out.complete().is_none(), "{order:?}");
            } else {
                assert_eq!(out.complete(), Some(&text[..]), "{order:?}");
            }
        }
        assert_eq!(r.stats().reordered, reordered);
        assert_eq!(reordered == 0, order == [0, 1, 2, 3]);
    }
}

#[test]
fn every_single_lost_chunk_is_detected() {
    let parts = chunks_of(SONAR, TEXT);
    for lost in 0..parts.len() {
        let mut r = Reassembler::<64>::new(SONAR);
        for (i, part) in parts.iter().enumerate() {
            if i != lost {
                assert!(r.push_message(part).complete().is_none(), "lost {lost}");
            }
        }
        assert!(!r.is_complete());
        assert_eq!(r.missing().collect::<Vec<_>>(), [lost as u8]);
        assert_eq!(r.missing_count(), 1);
        // The module sends its text again.
        let out = r.push_message(&parts[0]);
        if lost == 0 {
            // The missing chunk 0 comes late: placed by number, complete.
            assert!(out.reordered && out.lost.is_none());
            assert_eq!(out.complete(), Some(TEXT));
        } else {
            assert_eq!(
                out.lost,
                Some(Lost {
                    chunks: 5,
                    received: 4,
                    missing: 1
                })
            );
            assert!(out.complete().is_none());
            assert_eq!(r.stats().lost, 1);
            for part in &parts[1..] {
                let _ = r.push_message(part);
            }
            assert_eq!(r.text(), Some(TEXT));
        }
    }
}

#[test]
fn a_conflicting_duplicate_drops_the_transfer() {
    let parts = chunks_of(SONAR, TEXT);
    let mut r = Reassembler::<64>::new(SONAR);
    let _ = r.push_message(&parts[0]);
    let _ = r.push_message(&parts[1]);
    assert_eq!(
        r.push_message(&parts[1]).progress,
        Progress::Duplicate { chunk: 1 }
    );
    let Message::Piecewise { data, .. } = parts[1] else {
        unreachable!()
    };
    let mut other = data;
    other[3] ^= 0x20;
    assert_eq!(
        r.push(1, 5, &other).progress,
        Progress::Conflict {
            chunk: 1,
            chunks: 5
        }
    );
    assert_eq!(r.chunks(), None);
    assert_eq!(r.stats().conflicts, 1);
    // The rest of that transfer cannot complete it; the next one does.
    for part in &parts[2..] {
        assert!(r.push_message(part).complete().is_none());
    }
    let _ = r.push_message(&parts[0]);
    let out = r.push_message(&parts[1]);
    assert_eq!(out.complete(), Some(TEXT));
}

#[test]
fn a_chunk_count_change_starts_a_new_transfer() {
    let old = chunks_of(SONAR, TEXT);
    let new = chunks_of(SONAR, b"sonar, v2");
    assert_eq!(new.len(), 2);
    let mut r = Reassembler::<64>::new(SONAR);
    let _ = r.push_message(&old[0]);
    let _ = r.push_message(&old[1]);
    let _ = r.push_message(&old[2]);
    let out = r.push_message(&new[1]);
    assert_eq!(
        out.lost,
        Some(Lost {
            chunks: 5,
            received: 3,
            missing: 2
        })
    );
    assert_eq!(
        out.progress,
        Progress::Pending {
            received: 1,
            chunks: 2
        }
    );
    // A stray chunk of the old transfer is a change of count again.
    let out = r.push_message(&old[3]);
    assert_eq!(out.lost.map(|l| l.chunks), Some(2));
    let out = r.push_message(&new[0]);
    assert_eq!(out.lost.map(|l| l.chunks), Some(5));
    let out = r.push_message(&new[1]);
    assert_eq!(out.complete(), Some(&b"sonar, v2"[..]));
    assert_eq!(
        r.push_message(&new[0]).progress,
        Progress::Duplicate { chunk: 0 }
    );
    assert_eq!(r.text(), Some(&b"sonar, v2"[..]));
    // Once complete, a text of another length simply replaces it.
    let out = r.push_message(&old[0]);
    assert!(out.lost.is_none());
    assert_eq!(r.stats().lost, 3);
}

#[test]
fn a_text_longer_than_the_buffer_never_completes() {
    let parts = chunks_of(SONAR, TEXT);
    let mut r = Reassembler::<28>::new(SONAR); // TEXT has 29 bytes
    let mut too_long = 0;
    for _ in 0..3 {
        for part in &parts {
            let out = r.push_message(part);
            assert!(out.complete().is_none());
            if matches!(out.progress, Progress::TooLong { .. }) {
                too_long += 1;
            }
        }
    }
    assert_eq!(too_long, 3);
    assert_eq!(r.stats().too_long, 3);
    assert_eq!(r.stats().completed, 0);
    // One byte more of buffer is enough.
    let mut r = Reassembler::<29>::new(SONAR);
    for part in &parts {
        let _ = r.push_message(part);
    }
    assert_eq!(r.text(), Some(TEXT));
}

#[test]
fn out_of_range_chunks_change_nothing() {
    let parts = chunks_of(SONAR, TEXT);
    let mut r = Reassembler::<64>::new(SONAR);
    let _ = r.push_message(&parts[0]);
    for (chunk, chunks) in [(5, 5), (9, 5), (0, 0), (255, 255)] {
        assert_eq!(
            r.push(chunk, chunks, &[7; 7]).progress,
            Progress::OutOfRange { chunk, chunks }
        );
    }
    for part in &parts[1..] {
        let _ = r.push_message(part);
    }
    assert_eq!(r.text(), Some(TEXT));
    assert_eq!(r.stats().out_of_range, 4);
}

#[test]
fn the_longest_array_reassembles() {
    let text: Vec<u8> = (0..1785).map(|i| b'a' + (i % 26) as u8).collect();
    let mut parts = chunks_of(1, &text);
    assert_eq!(parts.len(), 255);
    parts.reverse();
    let mut r = Reassembler::<1785>::new(1);
    let mut done = None;
    for part in &parts {
        if let Some(array) = r.push_message(part).complete() {
            done = Some(array.to_vec());
        }
    }
    assert_eq!(done.as_deref(), Some(&text[..]));
    assert_eq!(r.stats().reordered, 254);
}

#[test]
fn a_leader_application_reassembles_info_texts_on_the_side() {
    // The leader keeps no text buffers; the application feeds a reassembler.
    let mut leader = leader();
    let mut text = Reassembler::<64>::new(SONAR);
    let mut got = None;
    for part in chunks_of(SONAR, TEXT) {
        let forward = leader.receive(Port::Network(SENSORS), &part);
        assert!(forward.upstream);
        if let Some(done) = text.push_message(&part).complete() {
            got = Some(done.to_vec());
        }
    }
    assert_eq!(got.as_deref(), Some(TEXT));
    assert_eq!(commands_of(&drain(&mut leader, 0)), SONAR_COMMANDS);
}

proptest! {
    #[test]
    fn reassembler_matches_its_rules(data in proptest::collection::vec(any::<u8>(), 0..400)) {
        scripts::check_reassembler(&data);
    }

    #[test]
    fn own_chunks_complete_only_into_the_array(data in proptest::collection::vec(any::<u8>(), 0..200)) {
        scripts::check_text(&data);
    }

    #[test]
    fn any_order_of_any_array(
        text in proptest::collection::vec(1u8..=255, 0..120),
        keys in proptest::collection::vec(any::<u32>(), 18),
    ) {
        // A permutation of the chunks (sorted by random keys): completes into the array
        // exactly at the last chunk, or never when it is longer than the buffer.
        let parts = chunks_of(3, &text);
        let mut order: Vec<usize> = (0..parts.len()).collect();
        order.sort_by_key(|&i| keys[i]);
        let mut r = Reassembler::<100>::new(3);
        for (step, &i) in order.iter().enumerate() {
            let out = r.push_message(&parts[i]);
            let last = step + 1 == order.len();
            prop_assert!(out.lost.is_none());
            match out.complete() {
                Some(array) => {
                    prop_assert!(last);
                    prop_assert_eq!(array, &text[..]);
                }
                None => prop_assert!(!last || text.len() > 100),
            }
        }
    }

    #[test]
    fn can_decoding(data in proptest::collection::vec(any::<u8>(), 0..16)) {
        scripts::check_can(&data);
    }

    #[test]
    fn can_decoding_of_valid_ids(ty in 0u32..4, mi in any::<u16>(), vi in any::<u8>(), len in 0u8..10, bytes in any::<[u8; 9]>()) {
        let id = ty << 24 | u32::from(mi) << 8 | u32::from(vi);
        let mut data = id.to_le_bytes().to_vec();
        data.push(len);
        data.extend_from_slice(&bytes);
        scripts::check_can(&data);
    }
}

#[test]
fn the_power_up_announcement_after_publications_is_no_restart() {
    let mut leader = leader();
    // An engine's first poll publishes its rated variables, then starts its info text.
    let _ = leader.observe(BODY, &publication(DRIVE_LEFT, 0));
    assert_eq!(
        leader.observe(BODY, &chunk(DRIVE_LEFT, 0, 1)),
        Observed::Known { instance: 1 }
    );
    assert_eq!(commands_of(&drain(&mut leader, 0)), DRIVE_LEFT_COMMANDS);
    assert_eq!(
        leader.observe(BODY, &chunk(DRIVE_LEFT, 0, 1)),
        Observed::Restarted { instance: 1 }
    );
    assert_eq!(leader.stats().restarted, 1);
}
