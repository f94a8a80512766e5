//! Property tests: every message round-trips through framing; arbitrary bytes and corrupted
//! frames never panic the decoder and are never accepted as a different message.

use proptest::prelude::*;
use rig_protocol::frame::{Decoder, MAX_WIRE_FRAME, encode_frame};
use rig_protocol::message::{
    FaultCause, FaultReport, FaultSet, Identity, Message, NackReason, RigState, Sample, Status,
};

fn finite() -> impl Strategy<Value = f32> {
    prop_oneof![
        any::<f32>().prop_filter("finite", |v| v.is_finite()),
        -1e4f32..1e4f32
    ]
}

fn cause() -> impl Strategy<Value = FaultCause> {
    proptest::sample::select(FaultCause::ALL.to_vec())
}

fn reason() -> impl Strategy<Value = NackReason> {
    use NackReason::*;
    proptest::sample::select(vec![
        NotArmed,
        Armed,
        Faulted,
        HandshakeRequired,
        BadArgument,
        Busy,
        NotTared,
        VersionMismatch,
        SensorFailure,
    ])
}

fn state() -> impl Strategy<Value = RigState> {
    proptest::sample::select(vec![RigState::Disarmed, RigState::Armed, RigState::Faulted])
}

fn sample() -> impl Strategy<Value = Sample> {
    (any::<u64>(), finite(), finite(), finite(), any::<u16>()).prop_map(|(t, th, i, v, u)| Sample {
        time_us: t,
        thrust_g: th,
        current_a: i,
        voltage_v: v,
        throttle_us: u,
    })
}

fn status() -> impl Strategy<Value = Status> {
    (
        any::<u64>(),
        state(),
        0u8..128,
        any::<u16>(),
        any::<u16>(),
        any::<u16>(),
        any::<u32>(),
        any::<u32>(),
        any::<u8>(),
    )
        .prop_map(|(t, st, f, th, tt, r, ok, dr, cp)| Status {
            time_us: t,
            state: st,
            faults: FaultSet(f),
            throttle_us: th,
            target_throttle_us: tt,
            stream_rate_hz: r,
            rx_frames_ok: ok,
            rx_frames_dropped: dr,
            calibration_points: cp,
        })
}

fn identity() -> impl Strategy<Value = Identity> {
    (
        any::<u16>(),
        any::<[u8; 3]>(),
        any::<u32>(),
        any::<u8>(),
        any::<u16>(),
        any::<u16>(),
        any::<u16>(),
    )
        .prop_map(|(pv, fw, sn, b, lo, hi, r)| Identity {
            protocol_version: pv,
            firmware_version: fw,
            serial_number: sn,
            board: b,
            throttle_min_us: lo,
            throttle_max_us: hi,
            max_stream_rate_hz: r,
        })
}

fn message() -> impl Strategy<Value = Message> {
    let seq = any::<u16>();
    prop_oneof![
        any::<u16>().prop_map(|v| Message::Hello {
            protocol_version: v
        }),
        Just(Message::Identify),
        Just(Message::Arm),
        Just(Message::Disarm),
        any::<u16>().prop_map(|n| Message::Tare { samples: n }),
        finite().prop_map(|m| Message::Calibrate { known_mass_g: m }),
        any::<u16>().prop_map(|t| Message::SetThrottle { throttle_us: t }),
        any::<u16>().prop_map(|r| Message::StartStream { rate_hz: r }),
        Just(Message::StopStream),
        Just(Message::GetStatus),
        Just(Message::Ping),
        (seq, any::<u16>(), any::<bool>()).prop_map(|(s, v, a)| Message::HelloAck {
            request_seq: s,
            protocol_version: v,
            accepted: a
        }),
        (seq, identity()).prop_map(|(s, identity)| Message::Identity {
            request_seq: s,
            identity
        }),
        seq.prop_map(|s| Message::Ack { request_seq: s }),
        (seq, reason()).prop_map(|(s, reason)| Message::Nack {
            request_seq: s,
            reason
        }),
        (seq, any::<i32>()).prop_map(|(s, o)| Message::TareDone {
            request_seq: s,
            offset_counts: o
        }),
        (seq, finite(), any::<u8>()).prop_map(|(s, k, p)| Message::Calibrated {
            request_seq: s,
            scale_g_per_count: k,
            points: p
        }),
        sample().prop_map(Message::Sample),
        (seq, status()).prop_map(|(s, status)| Message::Status {
            request_seq: s,
            status
        }),
        (any::<u64>(), cause(), finite(), finite()).prop_map(|(t, c, v, l)| Message::Fault(
            FaultReport {
                time_us: t,
                cause: c,
                value: v,
                limit: l
            }
        )),
    ]
}

fn wire(seq: u16, m: &Message) -> Vec<u8> {
    let mut buf = [0u8; MAX_WIRE_FRAME];
    let n = encode_frame(seq, m, &mut buf).unwrap();
    buf[..n].to_vec()
}

fn decode_all(
    dec: &mut Decoder,
    bytes: &[u8],
) -> Vec<Result<rig_protocol::Frame, rig_protocol::FrameError>> {
    bytes.iter().filter_map(|&b| dec.push(b)).collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn every_message_round_trips(seq in any::<u16>(), m in message()) {
        let w = wire(seq, &m);
        prop_assert!(w.len() <= MAX_WIRE_FRAME);
        prop_assert_eq!(*w.last().unwrap(), 0);
        prop_assert!(!w[..w.len() - 1].contains(&0));
        let mut dec = Decoder::new();
        let got = decode_all(&mut dec, &w);
        prop_assert_eq!(got.len(), 1);
        let f = got[0].unwrap();
        prop_assert_eq!(f.seq, seq);
        prop_assert_eq!(f.message, m);
        prop_assert_eq!(dec.stats().frames_ok, 1);
    }

    #[test]
    fn a_stream_of_messages_round_trips(msgs in proptest::collection::vec(message(), 1..20)) {
        let mut bytes = Vec::new();
        for (i, m) in msgs.iter().enumerate() {
            bytes.extend(wire(i as u16, m));
        }
        let mut dec = Decoder::new();
        let got: Vec<_> = decode_all(&mut dec, &bytes).into_iter().map(|r| r.unwrap().message).collect();
        prop_assert_eq!(got, msgs);
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..2000)) {
        let mut dec = Decoder::new();
        let results = decode_all(&mut dec, &bytes);
        let s = dec.stats();
        prop_assert_eq!(results.len() as u32, s.frames_ok + s.dropped());
    }

    /// Flip bits (never creating or destroying a delimiter) or drop a byte inside a frame:
    /// the frame is rejected and counted once, and the next frame still decodes.
    #[test]
    fn corrupted_frames_are_rejected_and_decoder_resyncs(
        m in message(), next in message(),
        pos in any::<proptest::sample::Index>(), mask in 1u8..=255, drop in any::<bool>(),
    ) {
        let w = wire(1, &m);
        let body = w.len() - 1;
        let i = pos.index(body);
        let mut bad = w.clone();
        if drop {
            bad.remove(i);
        } else {
            let flipped = bad[i] ^ mask;
            prop_assume!(flipped != 0);
            bad[i] = flipped;
        }
        let mut dec = Decoder::new();
        let mut bytes = bad;
        bytes.extend(wire(2, &next));
        let got = decode_all(&mut dec, &bytes);
        prop_assert_eq!(got.len(), 2);
        prop_assert!(got[0].is_err(), "corrupted frame accepted: {:?}", got[0]);
        prop_assert_eq!(got[1].unwrap().message, next);
        prop_assert_eq!(dec.stats().dropped(), 1);
    }
}

#[test]
fn truncated_and_oversized_frames_are_counted() {
    let mut dec = Decoder::new();
    let w = wire(3, &Message::Sample(Sample::default()));
    // truncated: a frame cut short then a delimiter
    let mut bytes = w[..w.len() / 2].to_vec();
    bytes.push(0);
    // oversized: a long run without delimiter
    bytes.extend(std::iter::repeat_n(0x55u8, 500));
    bytes.push(0);
    bytes.extend(&w);
    let got = decode_all(&mut dec, &bytes);
    assert_eq!(got.len(), 3);
    let s = dec.stats();
    assert_eq!(s.frames_ok, 1);
    assert_eq!(s.oversize, 1);
    assert_eq!(s.malformed + s.crc_errors, 1);
}
