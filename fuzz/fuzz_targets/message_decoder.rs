//! Fuzz message decoding behind a valid CRC: the input is wrapped into a correctly
//! checksummed, stuffed frame, so the fuzzer reaches every message parser. Decoding must
//! never panic, and anything accepted must re-encode to the same bytes.
#![no_main]

use libfuzzer_sys::fuzz_target;
use rig_protocol::cobs;
use rig_protocol::crc::crc32c;
use rig_protocol::frame::{Decoder, MAX_RAW_FRAME, MAX_WIRE_FRAME, decode_raw, encode_frame};

fuzz_target!(|data: &[u8]| {
    if data.len() + 4 > MAX_RAW_FRAME {
        return;
    }
    let mut raw = [0u8; MAX_RAW_FRAME];
    raw[..data.len()].copy_from_slice(data);
    let crc = crc32c(data);
    raw[data.len()..data.len() + 4].copy_from_slice(&crc.to_le_bytes());
    let raw = &raw[..data.len() + 4];
    let direct = decode_raw(raw);
    let mut wire = [0u8; MAX_WIRE_FRAME];
    let n = cobs::encode(raw, &mut wire[..MAX_WIRE_FRAME - 1]).expect("fits");
    wire[n] = 0;
    let mut dec = Decoder::new();
    let via_decoder: Vec<_> = wire[..=n].iter().filter_map(|&b| dec.push(b)).collect();
    assert_eq!(via_decoder.len(), 1);
    assert_eq!(via_decoder[0].is_ok(), direct.is_ok());
    if let Ok(frame) = direct {
        let mut again = [0u8; MAX_WIRE_FRAME];
        let m = encode_frame(frame.seq, &frame.message, &mut again).expect("encodes");
        assert_eq!(&again[..m], &wire[..=n], "re-encoding differs");
    }
});
