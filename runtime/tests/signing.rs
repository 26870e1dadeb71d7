//! MAVLink 2 signing: the golden frame, tampering, replays, new-stream age and a full table.

mod common;

use common::*;
use ferrolink_runtime::mavlink::parser::Parser;
use ferrolink_runtime::mavlink::signing::{
    signature_matches, SecretKey, Signer, Verifier, VerifyError, NEW_STREAM_WINDOW,
};
use ferrolink_runtime::mavlink::{v2, Header};

fn key() -> SecretKey {
    SecretKey::new(GOLDEN_KEY)
}

fn signed(signer: &mut Signer, now: u64, header: Header) -> Vec<u8> {
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = signer
        .encode(now, header, &golden_heartbeat(), &mut out)
        .unwrap();
    out[..n].to_vec()
}

fn verify<const S: usize>(v: &mut Verifier<S>, bytes: &[u8], now: u64) -> Result<(), VerifyError> {
    v.verify(&v2::Frame::new_checked(bytes).unwrap(), now)
}

#[test]
fn golden_frame_signed_and_verified() {
    let golden = hex(GOLDEN_SIGNED);
    let mut signer = Signer::new(key(), GOLDEN_LINK);
    assert_eq!(
        signed(&mut signer, GOLDEN_TIMESTAMP, Header::new(0, 1, 1)),
        golden
    );

    // Through the parser, then the verifier.
    let mut parser: Parser = Parser::for_dialect::<TestDialect>();
    let mut verifier = Verifier::<4>::new(key());
    let mut seen = 0;
    for chunk in golden.chunks(5) {
        parser.feed_all(chunk, |f| {
            let frame = f.as_v2().unwrap();
            assert_eq!(verifier.verify(frame, 0), Ok(()));
            seen += 1;
        });
    }
    assert_eq!(seen, 1);
    assert_eq!(
        verifier.timestamp(),
        GOLDEN_TIMESTAMP,
        "local time follows accepted frames"
    );
}

#[test]
fn tampered_frames_are_rejected() {
    let golden = hex(GOLDEN_SIGNED);
    // Any changed byte, with the checksum repaired where the change is before it, fails.
    for at in 0..golden.len() {
        if at == 1 || at == 2 {
            continue; // length and flags change the frame's shape, not just its content
        }
        for bit in [0x01, 0x80] {
            let mut t = golden.clone();
            t[at] ^= bit;
            if at < 19 {
                fix_crc(&mut t, 50);
            }
            let mut v = Verifier::<4>::new(key());
            let frame = v2::Frame::new_unchecked(&t[..]);
            if at == 0 {
                assert!(v2::Frame::new_checked(&t[..]).is_err());
                continue;
            }
            assert_eq!(
                v.verify(&frame, 0),
                Err(VerifyError::BadSignature),
                "byte {at}"
            );
        }
    }
    // A wrong key.
    let mut v = Verifier::<4>::new(SecretKey::new([0; 32]));
    assert_eq!(verify(&mut v, &golden, 0), Err(VerifyError::BadSignature));
    assert_eq!(v.stats().bad_signature, 1);
    // The trailer cut off.
    let f = v2::Frame::new_unchecked(&golden[..golden.len() - 1]);
    assert!(!signature_matches(&key(), &f));
    assert_eq!(
        Verifier::<1>::new(key()).verify(&f, 0),
        Err(VerifyError::BadSignature)
    );
    // Unsigned frames.
    let mut v = Verifier::<1>::new(key());
    assert_eq!(
        verify(&mut v, &hex(GOLDEN_V2), 0),
        Err(VerifyError::Unsigned)
    );
    assert_eq!(v.stats().unsigned, 1);
}

#[test]
fn replays_are_rejected_per_stream() {
    let now = 1_000_000_000;
    let mut signer = Signer::new(key(), 1);
    let a1 = signed(&mut signer, now, Header::new(0, 1, 1));
    let a2 = signed(&mut signer, now, Header::new(1, 1, 1));
    let mut v = Verifier::<4>::new(key());
    assert_eq!(verify(&mut v, &a1, now), Ok(()));
    assert_eq!(verify(&mut v, &a2, now), Ok(()));
    assert_eq!(
        verify(&mut v, &a2, now),
        Err(VerifyError::Replayed),
        "same timestamp"
    );
    assert_eq!(
        verify(&mut v, &a1, now),
        Err(VerifyError::Replayed),
        "older timestamp"
    );
    assert_eq!(v.stats().replayed, 2);

    // The same timestamp on another stream (other compid, other link) is fine.
    let mut signer = Signer::new(key(), 1);
    let b1 = signed(&mut signer, now, Header::new(0, 1, 2));
    assert_eq!(verify(&mut v, &b1, now), Ok(()));
    let mut signer = Signer::new(key(), 2);
    let c1 = signed(&mut signer, now, Header::new(0, 1, 1));
    assert_eq!(verify(&mut v, &c1, now), Ok(()));
    assert_eq!(v.streams().count(), 3);
}

#[test]
fn new_streams_must_be_recent() {
    let now = 50 * NEW_STREAM_WINDOW;
    let mut v = Verifier::<4>::new(key());

    let mut old = Signer::new(key(), 1);
    let frame = signed(&mut old, now - NEW_STREAM_WINDOW - 1, Header::new(0, 1, 1));
    assert_eq!(verify(&mut v, &frame, now), Err(VerifyError::TooOld));
    assert_eq!(v.stats().too_old, 1);
    assert_eq!(v.streams().count(), 0);

    let frame = signed(&mut old, now - NEW_STREAM_WINDOW, Header::new(0, 1, 1));
    assert_eq!(
        verify(&mut v, &frame, now),
        Ok(()),
        "exactly 60 s behind is accepted"
    );

    // Once known, a stream may lag behind local time as long as it increases.
    let frame = signed(&mut old, 0, Header::new(1, 1, 1));
    assert_eq!(verify(&mut v, &frame, now + 10 * NEW_STREAM_WINDOW), Ok(()));

    // A verifier without a clock follows the newest accepted timestamp.
    let mut v = Verifier::<4>::new(key());
    let mut fresh = Signer::new(key(), 1);
    assert_eq!(
        verify(&mut v, &signed(&mut fresh, now, Header::new(0, 9, 9)), 0),
        Ok(())
    );
    let mut stale = Signer::new(key(), 1);
    let frame = signed(
        &mut stale,
        now - NEW_STREAM_WINDOW - 1,
        Header::new(0, 8, 8),
    );
    assert_eq!(verify(&mut v, &frame, 0), Err(VerifyError::TooOld));
}

#[test]
fn full_table_evicts_the_stream_updated_longest_ago() {
    let now = 10 * NEW_STREAM_WINDOW;
    let mut v = Verifier::<2>::new(key());
    let mut a = Signer::new(key(), 1);
    let mut b = Signer::new(key(), 2);
    let mut c = Signer::new(key(), 3);

    let a1 = signed(&mut a, now, Header::new(0, 1, 1));
    let b1 = signed(&mut b, now, Header::new(0, 1, 1));
    let a2 = signed(&mut a, now, Header::new(1, 1, 1));
    let c1 = signed(&mut c, now, Header::new(0, 1, 1));
    assert_eq!(verify(&mut v, &a1, now), Ok(()));
    assert_eq!(verify(&mut v, &b1, now), Ok(()));
    assert_eq!(
        verify(&mut v, &a2, now),
        Ok(()),
        "a is now the most recently updated"
    );
    assert_eq!(verify(&mut v, &c1, now), Ok(()), "c replaces b");
    assert_eq!(v.stats().evicted, 1);
    let mut links: Vec<u8> = v.streams().map(|s| s.link_id).collect();
    links.sort_unstable();
    assert_eq!(links, [1, 3]);

    // Remembered streams stay protected.
    assert_eq!(verify(&mut v, &a2, now), Err(VerifyError::Replayed));
    assert_eq!(verify(&mut v, &c1, now), Err(VerifyError::Replayed));
    // The forgotten stream is back to the new-stream rule: a recent frame is accepted again
    // (the documented cost of eviction), which in turn evicts the least recently used stream.
    assert_eq!(verify(&mut v, &b1, now), Ok(()));
    assert_eq!(v.stats().evicted, 2);

    v.forget_streams();
    assert_eq!(v.streams().count(), 0);
}
