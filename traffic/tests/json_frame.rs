//! JSON to MAVLink frames on hand-picked inputs; `cargo fuzz run json_frame` checks the same
//! invariants on arbitrary ones (`tests/scripts/traffic.rs`).

#[path = "scripts/traffic.rs"]
mod scripts;

#[test]
fn json_frames_hold_their_invariants() {
    let inputs: &[&str] = &[
        r#"{"mavpackettype":"HEARTBEAT","type":2,"autopilot":3,"base_mode":81,"custom_mode":7,"system_status":4,"mavlink_version":3}"#,
        r#"{"sysid":1,"compid":1,"seq":9,"msg":{"mavpackettype":"ATTITUDE","time_boot_ms":1,"roll":0.1,"pitch":null,"yaw":-0.0,"rollspeed":1e38,"pitchspeed":0,"yawspeed":3}}"#,
        r#"{"mavpackettype":"STATUSTEXT","severity":4,"text":"Ünïcode fits","id":2,"chunk_seq":1}"#,
        r#"{"mavpackettype":"STATUSTEXT","text":"this text is longer than the fifty bytes a STATUSTEXT holds"}"#,
        r#"{"mavpackettype":"PING","seq":4294967296}"#,
        r#"{"sysid":1,"msg":null,"id":5,"payload":"00"}"#,
        r#"{"sysid":-1,"msg":{"mavpackettype":"PING"}}"#,
        r#"[1,2,3]"#,
        r#"{"mavpackettype":"PING","target_system":[1]}"#,
        r#"{"mavpackettype":"PING"}"#,
    ];
    for input in inputs {
        for defaults in [[0u8, 0, 0], [255, 190, 7]] {
            let mut data = defaults.to_vec();
            data.extend_from_slice(input.as_bytes());
            scripts::check_json_frame(&data);
        }
    }
}
