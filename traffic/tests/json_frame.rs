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

#[test]
fn the_rest_form_reads_back_what_it_writes() {
    let inputs: &[&str] = &[
        r#"{"type":"HEARTBEAT","mavtype":{"type":"MAV_TYPE_QUADROTOR"},"autopilot":3,"base_mode":"MAV_MODE_FLAG_SAFETY_ARMED | 0x1","custom_mode":7,"system_status":{"type":"MAV_STATE_ACTIVE"},"mavlink_version":3}"#,
        r#"{"type":"HEARTBEAT","base_mode":{"bits":129}}"#,
        r#"{"type":"HEARTBEAT","base_mode":"NOT_A_FLAG"}"#,
        r#"{"type":"ATTITUDE","roll":null,"pitch":1e39,"time_boot_ms":4294967295}"#,
        r#"{"type":"STATUSTEXT","text":"a\u0000b","severity":{"type":"MAV_SEVERITY_INFO"}}"#,
        r#"{"type":"NOPE"}"#,
        r#"{"type":"ATTITUDE","nope":1}"#,
    ];
    for input in inputs {
        let mut data = vec![0u8];
        data.extend_from_slice(input.as_bytes());
        scripts::check_rest_json(&data);
    }
    for pick in 0..=255u8 {
        scripts::check_rest_json(&[1, pick, 0xff, 0x80, 0, 1, 2, 3, 0xfe, 0xc3, 0x28]);
    }
}
