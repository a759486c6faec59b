//! The stream's frames encoded and decoded: every field in its place, every version read.

use super::*;

const H: Header = Header {
    first_sample: 64,
    rh_pct: 46.5,
    rh_strip_pct: 46.625,
    rh_read_pct: 49.25,
    rel_err: 0.0625,
    hygrometer: Hygrometer { read_sd_pct: 1.5, own_pct: 45.75, own_sd_pct: 0.25, own_refusal: 0, fused_pct: 45.875, fused_sd_pct: 0.125 },
    flags: 0b1001,
    setup: Some(Setup { band_shape: 1, delay_samples: 470, humidity_mode: 1 }),
};

fn frame(header: &Header, est: &[f32]) -> ([u8; MAX_FRAME_LEN], usize) {
    frame_with(header, est, None)
}

fn frame_with(header: &Header, est: &[f32], check: Option<Check<'_>>) -> ([u8; MAX_FRAME_LEN], usize) {
    let mut out = [0u8; MAX_FRAME_LEN];
    let n = encode(header, est, check, &mut out).unwrap();
    (out, n)
}

#[test]
fn round_trip_of_every_length() {
    for n in 0..=MAX_ESTIMATES {
        let est: [f32; MAX_ESTIMATES] = core::array::from_fn(|k| (k as f32 - 100.0) * 1e-4);
        let cur: [f32; MAX_ESTIMATES] = core::array::from_fn(|k| (k as f32 * 0.11).cos() * 3e-6);
        let acc: [f32; MAX_ESTIMATES] = core::array::from_fn(|k| (k as f32 * 0.37).sin() * 150.0);
        let window = (n % 2 == 1).then_some(ErrorWindow { end_sample: 10_000 + n as u32, measured: 0.1875, stated: 0.125 });
        for check in [None, Some(Check { first_sample: 7, current_a: &cur[..n], accel_mps2: &acc[..n], window })] {
            let (mut out, len) = frame_with(&H, &est[..n], check);
            assert!(len <= max_frame_len(n));
            assert_eq!(out[len - 1], 0);
            assert!(!out[..len - 1].contains(&0));
            // The streaming encoder gives the one-shot encoder's bytes (what v1 sent).
            let encoded = out;
            let mut payload = out;
            let p = cobs::decode_in_place(&mut payload[..len - 1]).unwrap();
            assert_eq!(p, payload_len(n, check.is_some()));
            let mut again = [0u8; MAX_FRAME_LEN];
            assert_eq!(cobs::encode(&payload[..p], &mut again), len - 1);
            assert_eq!(again[..len - 1], encoded[..len - 1]);
            let f = decode(&mut out[..len - 1]).unwrap();
            assert_eq!(f.header, H);
            assert_eq!(f.len(), n);
            assert!(f.estimates().eq(est[..n].iter().copied()));
            match check {
                Some(c) => {
                    assert_eq!(f.check_first_sample(), Some(7));
                    assert!(f.currents().expect("the check's current").eq(c.current_a.iter().copied()));
                    assert!(f.accelerations().expect("the check's accelerations").eq(c.accel_mps2.iter().copied()));
                    assert_eq!(f.error_window(), window);
                }
                None => assert!(
                    f.currents().is_none() && f.accelerations().is_none() && f.check_first_sample().is_none() && f.error_window().is_none()
                ),
            }
        }
    }
}

/// The layout documented above, byte for byte, before COBS.
#[test]
fn payload_layout() {
    let window = Some(ErrorWindow { end_sample: 30_000, measured: 0.25, stated: 0.0625 });
    let check = Check { first_sample: 0, current_a: &[3e-6, -4e-6], accel_mps2: &[9.5, -0.25], window };
    let (mut out, len) = frame_with(&H, &[1.0, -2.0], Some(check));
    let n = cobs::decode_in_place(&mut out[..len - 1]).unwrap();
    let p = &out[..n];
    assert_eq!(n, payload_len(2, true));
    assert_eq!(p[0], FRAME_VERSION);
    assert_eq!(p[1..5], 64u32.to_le_bytes());
    assert_eq!(p[5..9], 46.5f32.to_le_bytes());
    assert_eq!(p[9..13], 46.625f32.to_le_bytes());
    assert_eq!(p[13..17], 49.25f32.to_le_bytes());
    assert_eq!(p[17..21], 0.0625f32.to_le_bytes());
    assert_eq!(p[21..25], 1.5f32.to_le_bytes());
    assert_eq!(p[25..29], 45.75f32.to_le_bytes());
    assert_eq!(p[29..33], 0.25f32.to_le_bytes());
    assert_eq!(p[33], 0);
    assert_eq!(p[34..38], 45.875f32.to_le_bytes());
    assert_eq!(p[38..42], 0.125f32.to_le_bytes());
    assert_eq!(p[42..44], 9u16.to_le_bytes());
    assert_eq!((p[44], &p[45..47], p[47]), (1, &470u16.to_le_bytes()[..], 1));
    assert_eq!(p[48], 1, "a check's samples follow");
    assert_eq!(p[49], 2);
    assert_eq!(p[50..54], 1.0f32.to_le_bytes());
    assert_eq!(p[54..58], (-2.0f32).to_le_bytes());
    assert_eq!(p[58..62], 0u32.to_le_bytes(), "the check's first sample");
    assert_eq!(p[62..66], 3e-6f32.to_le_bytes());
    assert_eq!(p[66..70], (-4e-6f32).to_le_bytes());
    assert_eq!(p[70..74], 9.5f32.to_le_bytes());
    assert_eq!(p[74..78], (-0.25f32).to_le_bytes());
    assert_eq!(p[78..82], 30_000u32.to_le_bytes(), "the window's end");
    assert_eq!(p[82..86], 0.25f32.to_le_bytes(), "the error measured");
    assert_eq!(p[86..90], 0.0625f32.to_le_bytes(), "the error stated");
    assert_eq!(p[90..92], CRC16.checksum(&p[..90]).to_le_bytes());
    // No window yet: its end says so, and the decoder gives none.
    let (mut out, len) = frame_with(&H, &[1.0, -2.0], Some(Check { window: None, ..check }));
    let n = cobs::decode_in_place(&mut out[..len - 1]).unwrap();
    assert_eq!(out[78..82], u32::MAX.to_le_bytes());
    assert!(out[82..90].chunks(4).all(|w| f32::from_le_bytes(w.try_into().unwrap()).is_nan()));
    let mut encoded = [0u8; MAX_FRAME_LEN];
    let m = cobs::encode(&out[..n], &mut encoded);
    assert_eq!(decode(&mut encoded[..m]).unwrap().error_window(), None);
    // Without the part: the byte says so and the estimates end the frame.
    let (mut out, len) = frame(&H, &[1.0, -2.0]);
    let n = cobs::decode_in_place(&mut out[..len - 1]).unwrap();
    assert_eq!((n, out[48], out[49]), (payload_len(2, false), 0, 2));
}

/// A check's samples are one per estimate, and only in a frame with a setup; a byte other
/// than 0 or 1 where the accelerometer's is refused.
#[test]
fn refuses_a_check_that_does_not_fit() {
    let mut out = [0u8; MAX_FRAME_LEN];
    let short = Check { first_sample: 0, current_a: &[1e-6, 2e-6], accel_mps2: &[3.0], window: None };
    assert_eq!(encode(&H, &[1.0, 2.0], Some(short), &mut out), Err(EncodeError::Check));
    let one = Check { first_sample: 0, current_a: &[1e-6], accel_mps2: &[3.0], window: None };
    assert_eq!(encode(&Header { setup: None, ..H }, &[1.0], Some(one), &mut out), Err(EncodeError::Check));
    let (mut out, len) = frame(&H, &[1.0]);
    let n = cobs::decode_in_place(&mut out[..len - 1]).unwrap();
    out[48] = 2;
    let crc = CRC16.checksum(&out[..n - 2]);
    out[n - 2..n].copy_from_slice(&crc.to_le_bytes());
    let mut encoded = [0u8; MAX_FRAME_LEN];
    let m = cobs::encode(&out[..n], &mut encoded);
    assert_eq!(decode(&mut encoded[..m]), Err(DecodeError::CheckMarker(2)));
}

/// A version 4 frame (a firmware of the release before the setup) is read as it was, with
/// no setup; its bytes are this layout without the setup's four and the accelerometer's byte.
#[test]
fn reads_the_version_before_the_setup() {
    let old = Header { setup: None, ..H };
    let (mut out, len) = frame(&old, &[1.0, -2.0]);
    let n = cobs::decode_in_place(&mut out[..len - 1]).unwrap();
    assert_eq!((out[0], n), (OLDEST_VERSION, payload_len(2, false) - SETUP_LEN - ACCEL_LEN));
    assert_eq!(out[44], 2, "the count right after the flags");
    let (mut again, len) = frame(&old, &[1.0, -2.0]);
    let f = decode(&mut again[..len - 1]).unwrap();
    assert_eq!((f.header, f.len()), (old, 2));
    assert!(f.accelerations().is_none());
}

/// A version 6 frame (the release before the running error): a check without its window,
/// read with its samples and no window.
#[test]
fn reads_the_version_before_the_window() {
    let window = Some(ErrorWindow { end_sample: 30_000, measured: 0.25, stated: 0.0625 });
    let check = Check { first_sample: 5, current_a: &[3e-6, -4e-6], accel_mps2: &[9.5, -0.25], window };
    let (mut out, len) = frame_with(&H, &[1.0, -2.0], Some(check));
    let n = cobs::decode_in_place(&mut out[..len - 1]).unwrap();
    // The payload less the window's three words, version 6.
    let body = n - 2 - 12;
    out[0] = VERSION_BEFORE_WINDOW;
    let crc = CRC16.checksum(&out[..body]);
    out[body..body + 2].copy_from_slice(&crc.to_le_bytes());
    let mut encoded = [0u8; MAX_FRAME_LEN];
    let m = cobs::encode(&out[..body + 2], &mut encoded);
    let f = decode(&mut encoded[..m]).unwrap();
    assert_eq!((f.header, f.len(), f.check_first_sample()), (H, 2, Some(5)));
    assert!(f.accelerations().expect("the check's accelerations").eq([9.5, -0.25]));
    assert_eq!(f.error_window(), None);
}

/// A version 5 frame (the release before the accelerometer): this layout without the
/// accelerometer's byte, read with its setup and no accelerations.
#[test]
fn reads_the_version_before_the_accelerometer() {
    let (mut out, len) = frame(&H, &[1.0, -2.0]);
    let n = cobs::decode_in_place(&mut out[..len - 1]).unwrap();
    let mut payload = [0u8; 64];
    payload[..48].copy_from_slice(&out[..48]);
    payload[0] = VERSION_BEFORE_ACCEL;
    payload[48..n - 3].copy_from_slice(&out[49..n - 2]);
    let body = n - 3;
    let crc = CRC16.checksum(&payload[..body]);
    payload[body..body + 2].copy_from_slice(&crc.to_le_bytes());
    let mut encoded = [0u8; MAX_FRAME_LEN];
    let m = cobs::encode(&payload[..body + 2], &mut encoded);
    let f = decode(&mut encoded[..m]).unwrap();
    assert_eq!((f.header, f.len()), (H, 2));
    assert!(f.estimates().eq([1.0, -2.0]));
    assert!(f.accelerations().is_none());
}

/// A frame of an older layout with a valid CRC: version, first sample 64, `n_rh` humidities
/// of 46.5 %, flags 0, one estimate of 1 m.
fn old_frame(version: u8, n_rh: usize, out: &mut [u8; 40]) -> usize {
    let mut payload = [0u8; 40];
    let mut at = 0;
    let mut put = |bytes: &[u8]| {
        payload[at..at + bytes.len()].copy_from_slice(bytes);
        at += bytes.len();
    };
    put(&[version]);
    put(&64u32.to_le_bytes());
    for _ in 0..n_rh {
        put(&46.5f32.to_le_bytes());
    }
    put(&0u16.to_le_bytes());
    put(&[1]);
    put(&1.0f32.to_le_bytes());
    let crc = CRC16.checksum(&payload[..at]);
    payload[at..at + 2].copy_from_slice(&crc.to_le_bytes());
    cobs::encode(&payload[..at + 2], out)
}

/// Frames of the layouts before this one (version 1: one RH; version 2: three humidities,
/// no expected error; version 3: no hygrometer) are refused by their version, with a
/// message that says what to do.
#[test]
fn refuses_the_previous_versions() {
    for (version, n_rh) in [(1, 1), (2, 3), (3, 4)] {
        let mut encoded = [0u8; 40];
        let n = old_frame(version, n_rh, &mut encoded);
        let e = decode(&mut encoded[..n]).unwrap_err();
        assert_eq!(e, DecodeError::Version(version));
        let shown = std::string::ToString::to_string(&e);
        assert!(shown.contains("different releases") && shown.contains("reads versions 4–7"), "{shown}");
    }
}

#[test]
fn refuses_bad_frames() {
    let (out, len) = frame(&H, &[1.0, 2.0, 3.0]);
    // Every single-bit flip of the frame body is rejected, never accepted or panicking.
    for i in 0..len - 1 {
        for bit in 0..8 {
            let mut bad = out;
            bad[i] ^= 1 << bit;
            assert!(decode(&mut bad[..len - 1]).is_err(), "flip of bit {bit} in byte {i} accepted");
        }
    }
    assert_eq!(encode(&H, &[0.0; 256], None, &mut [0u8; 4096]), Err(EncodeError::TooManyEstimates(256)));
    assert_eq!(encode(&H, &[0.0; 4], None, &mut [0u8; 20]), Err(EncodeError::BufferTooSmall));
    assert_eq!(decode(&mut [3, 1, 2]), Err(DecodeError::TooShort(2)));
    assert!(decode(&mut []).is_err());
}

#[test]
fn deframer_skips_garbage_and_resyncs() {
    let mut stream = [0u8; 4 * MAX_FRAME_LEN];
    let mut w = 0;
    let mut put = |bytes: &[u8]| {
        stream[w..w + bytes.len()].copy_from_slice(bytes);
        w += bytes.len();
    };
    put(&[7, 7, 0xFF, 0, 0]); // garbage, then a repeated delimiter
    let (f, n) = frame(&H, &[1.0]);
    put(&f[..n]);
    let (mut f, n) = frame(&Header { first_sample: 65, ..H }, &[2.0]);
    f[3] ^= 0x40; // corrupted on the wire
    put(&f[..n]);
    let (f, n) = frame(&Header { first_sample: 66, ..H }, &[3.0]);
    put(&f[..n]);
    put(&[0x55; MAX_FRAME_LEN + 3]); // no delimiter for too long
    put(&[0]);
    let (f, n) = frame(&Header { first_sample: 67, ..H }, &[4.0]);
    put(&f[..n]);

    let mut d = Deframer::<MAX_FRAME_LEN>::new();
    let (mut good, mut bad) = ([0u32; 8], 0);
    let mut n_good = 0;
    for &b in &stream[..w] {
        match d.push(b) {
            Some(Ok(frame)) => {
                good[n_good] = frame.header.first_sample;
                n_good += 1;
            }
            Some(Err(_)) => bad += 1,
            None => {}
        }
    }
    assert_eq!(&good[..n_good], &[64, 66, 67]);
    assert_eq!(bad, 3); // the garbage, the corrupted frame, the over-long run
}
