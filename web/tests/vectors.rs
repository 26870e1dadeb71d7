//! Our REST form of a message against mavlink2rest 1.0.2's, on 825 frames of 279 ardupilotmega
//! messages with random values (`vectors/mavlink2rest-1.0.2.jsonl`, taken from mavlink2rest
//! itself by `tests/mavlink/mavlink2rest_vectors.py`): every field, its name, its form (enums,
//! bit masks, text, arrays) and its value.

use ferrolink_runtime::mavlink::AnyFrame;
use ferrolink_traffic::Dialects;

#[test]
fn every_vector_reads_as_mavlink2rest_reads_it() {
    let decoder = Dialects::load(&["ardupilotmega".into()], "ardupilotmega")
        .expect("the built-in ardupilotmega")
        .decoder();
    let text = include_str!("vectors/mavlink2rest-1.0.2.jsonl");
    let mut checked = 0;
    for (i, line) in text.lines().enumerate() {
        let vector: serde_json::Value = serde_json::from_str(line).expect("a JSON line");
        let frame = hex::decode(vector["frame"].as_str().expect("frame")).expect("hex");
        let frame = AnyFrame::new_checked(&frame[..]).expect("a whole frame");
        let ours = decoder
            .to_rest(frame.msg_id(), frame.payload())
            .unwrap_or_else(|| panic!("line {}: unknown id {}", i + 1, frame.msg_id()));
        assert_eq!(ours, vector["message"], "line {}", i + 1);
        // And back: the same payload, zero-padded.
        let (id, payload) = decoder.from_rest(&vector["message"]).expect("reads back");
        assert_eq!(id, frame.msg_id());
        assert_eq!(
            &payload[..frame.payload().len()],
            frame.payload(),
            "line {}",
            i + 1
        );
        checked += 1;
    }
    assert_eq!(checked, 825);
}
