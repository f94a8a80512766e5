//! Fuzz the streaming frame decoder: arbitrary bytes must never panic it, every delimiter
//! yields at most one result, the counters add up, and anything it accepts re-encodes to a
//! frame that decodes to the same message.
#![no_main]

use libfuzzer_sys::fuzz_target;
use rig_protocol::frame::{Decoder, MAX_WIRE_FRAME, encode_frame};

fuzz_target!(|data: &[u8]| {
    let mut dec = Decoder::new();
    let mut results = 0u32;
    for &b in data {
        if let Some(r) = dec.push(b) {
            results += 1;
            if let Ok(frame) = r {
                let mut wire = [0u8; MAX_WIRE_FRAME];
                let n = encode_frame(frame.seq, &frame.message, &mut wire).expect("encodes");
                let mut again = Decoder::new();
                let back: Vec<_> = wire[..n].iter().filter_map(|&b| again.push(b)).collect();
                assert_eq!(back.len(), 1);
                let f2 = back[0].expect("re-encoded frame decodes");
                assert_eq!(f2.seq, frame.seq);
                // Compare encodings (NaN payloads compare unequal as floats).
                let mut wire2 = [0u8; MAX_WIRE_FRAME];
                let n2 = encode_frame(f2.seq, &f2.message, &mut wire2).expect("encodes");
                assert_eq!(&wire[..n], &wire2[..n2]);
            }
        }
    }
    let s = dec.stats();
    assert_eq!(results, s.frames_ok + s.dropped());
});
