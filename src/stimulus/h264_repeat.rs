//! A held picture shown again without running the encoder: an H.264 access unit whose one
//! P slice skips every macroblock, which a decoder reconstructs as an exact copy of the
//! previous picture, plus the frame renumbering that lets such units sit between the
//! encoder's own.
//!
//! Three of every four frames of a stimulus repeat a hold, and openh264 spends ~11 ms of
//! motion search on each though it can only find nothing; writing the skip unit here takes
//! microseconds. Why the copy is exact (H.264 §8.4.1.1, §8.7.2): a P_Skip macroblock's
//! motion vector is predicted from its neighbours, which are all P_Skip with vector 0 (or
//! unavailable, which also gives 0), so every vector is 0; it has no residual, and edges
//! between blocks with no coefficients, the same reference and the same vector have
//! boundary strength 0, so the deblocking filter changes nothing (and it is switched off
//! in the slice header anyway).
//!
//! The units are reference pictures, as the encoder's are: a non-reference picture would
//! need a picture order count between two of the encoder's, and with openh264's order-count
//! type 2 two non-reference pictures may not follow each other. So each repeat takes the
//! next `frame_num`, and the encoder's later slices are renumbered to continue after it.
//! With one reference frame (which the stream parameters are checked for), the encoder's
//! next P slice predicts from the newest reference, a repeat, which is the same picture as
//! the one the encoder itself holds as its reference; its reference-list commands, if any,
//! are relative to its own frame number and so still name that picture.
use crate::stimulus::video_error::H264StreamError;

/// What the repeat units need to know from the stream's parameter sets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct StreamParams {
    log2_max_frame_num: u32,
    pic_size_in_mbs: u32,
    pps_id: u32,
    deblocking_filter_control_present: bool,
}

/// Reads the SPS and PPS an encoder writes, renumbers its slices, and writes repeats.
#[derive(Debug, Default)]
pub struct RepeatWriter {
    sps: Option<SpsFields>,
    params: Option<StreamParams>,
    /// The `frame_num` the next access unit takes (None before the first IDR).
    next_frame_num: Option<u32>,
    /// The `nal_ref_idc` of the encoder's last slice, which repeats copy.
    nal_ref_idc: u8,
    rbsp: Vec<u8>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct SpsFields {
    sps_id: u32,
    log2_max_frame_num: u32,
    pic_size_in_mbs: u32,
}

impl RepeatWriter {
    pub fn new() -> RepeatWriter {
        RepeatWriter::default()
    }

    /// Copies one of the encoder's access units (Annex B) to `out`, with its slices'
    /// `frame_num` continuing after the repeats written so far.
    pub fn renumber(&mut self, annexb: &[u8], out: &mut Vec<u8>) -> Result<(), H264StreamError> {
        let mut slice_seen: Option<bool> = None; // Some(idr) once the unit's first slice is read
        for nal in nal_units(annexb) {
            let Some(&header) = nal.first() else {
                continue;
            };
            let nal_type = header & 0x1f;
            let ref_idc = (header >> 5) & 3;
            out.extend_from_slice(&[0, 0, 0, 1]);
            match nal_type {
                7 => {
                    unescape(&nal[1..], &mut self.rbsp);
                    self.sps = Some(parse_sps(&self.rbsp)?);
                    out.extend_from_slice(nal);
                }
                8 => {
                    unescape(&nal[1..], &mut self.rbsp);
                    let sps = self
                        .sps
                        .ok_or("the H.264 stream has a picture parameter set before any SPS")?;
                    self.params = Some(parse_pps(&self.rbsp, &sps)?);
                    out.extend_from_slice(nal);
                }
                1 | 5 => {
                    let params = self
                        .params
                        .ok_or("the H.264 stream has a slice before its parameter sets")?;
                    if ref_idc == 0 {
                        return Err(H264StreamError::from(
                            "the encoder wrote a non-reference picture; repeats \
                                    between its pictures need every picture to be a reference",
                        ));
                    }
                    self.nal_ref_idc = ref_idc;
                    let idr = nal_type == 5;
                    let frame_num = if idr {
                        0
                    } else {
                        self.next_frame_num
                            .ok_or("the H.264 stream does not begin with an IDR picture")?
                    };
                    unescape(&nal[1..], &mut self.rbsp);
                    let at = frame_num_position(&self.rbsp)?;
                    let bits = params.log2_max_frame_num;
                    if at + bits as usize > self.rbsp.len() * 8 {
                        return Err(H264StreamError::from(
                            "an H.264 slice header ends before its frame number",
                        ));
                    }
                    if read_bits_at(&self.rbsp, at, bits) == frame_num {
                        out.extend_from_slice(nal);
                    } else {
                        write_bits_at(&mut self.rbsp, at, bits, frame_num);
                        out.push(header);
                        escape(&self.rbsp, out);
                    }
                    slice_seen = Some(idr);
                }
                _ => out.extend_from_slice(nal),
            }
        }
        match slice_seen {
            Some(idr) => {
                let params = self.params.expect("set when a slice was read");
                let current = if idr {
                    0
                } else {
                    self.next_frame_num.expect("checked for the slice")
                };
                self.next_frame_num = Some((current + 1) % (1 << params.log2_max_frame_num));
                Ok(())
            }
            None => Err(H264StreamError::from(
                "the encoder's access unit holds no picture",
            )),
        }
    }

    /// Appends to `out` an access unit (Annex B) that shows the previous picture again.
    pub fn repeat(&mut self, out: &mut Vec<u8>) -> Result<(), H264StreamError> {
        let (Some(params), Some(frame_num)) = (self.params, self.next_frame_num) else {
            return Err(H264StreamError::from("a repeat needs a picture before it"));
        };
        let mut w = BitWriter::default();
        w.ue(0); // first_mb_in_slice
        w.ue(0); // slice_type: P
        w.ue(params.pps_id);
        w.bits(frame_num, params.log2_max_frame_num);
        // Picture order count type 2 (checked): nothing here.
        w.bits(1, 1); // num_ref_idx_active_override_flag
        w.ue(0); // num_ref_idx_l0_active_minus1: one reference
        w.bits(0, 1); // ref_pic_list_modification_flag_l0
        w.bits(0, 1); // adaptive_ref_pic_marking_mode_flag: sliding window
        w.se(0); // slice_qp_delta
        if params.deblocking_filter_control_present {
            w.ue(1); // disable_deblocking_filter_idc: off
        }
        w.ue(params.pic_size_in_mbs); // mb_skip_run: the whole picture
        w.trailing_bits();
        out.extend_from_slice(&[0, 0, 0, 1, (self.nal_ref_idc << 5) | 1]);
        escape(&w.bytes, out);
        self.next_frame_num = Some((frame_num + 1) % (1 << params.log2_max_frame_num));
        Ok(())
    }
}

/// The NAL units of an Annex B byte stream, without start codes.
fn nal_units(annexb: &[u8]) -> impl Iterator<Item = &[u8]> {
    let mut starts = Vec::new();
    let mut i = 0;
    while i + 3 <= annexb.len() {
        if annexb[i] == 0 && annexb[i + 1] == 0 && annexb[i + 2] == 1 {
            starts.push(i + 3);
            i += 3;
        } else {
            i += 1;
        }
    }
    let ends: Vec<usize> = starts
        .iter()
        .skip(1)
        .map(|&s| {
            // A unit ends before the next start code, and before a zero byte that is the
            // first of a four-byte start code.
            let mut e = s - 3;
            while e > 0 && annexb[e - 1] == 0 {
                e -= 1;
            }
            e
        })
        .chain(std::iter::once(annexb.len()))
        .collect();
    starts
        .into_iter()
        .zip(ends)
        .map(move |(s, e)| &annexb[s..e.max(s)])
}

/// Removes emulation-prevention bytes (§7.4.1): the 3 in every 00 00 03.
fn unescape(escaped: &[u8], rbsp: &mut Vec<u8>) {
    rbsp.clear();
    let mut zeros = 0;
    for &b in escaped {
        if zeros >= 2 && b == 3 {
            zeros = 0;
            continue;
        }
        zeros = if b == 0 { zeros + 1 } else { 0 };
        rbsp.push(b);
    }
}

/// Inserts emulation-prevention bytes so that no 00 00 0x (x ≤ 3) appears in the payload.
/// Every RBSP written here ends in its stop bit, so never in a zero byte.
fn escape(rbsp: &[u8], out: &mut Vec<u8>) {
    let mut zeros = 0;
    for &b in rbsp {
        if zeros >= 2 && b <= 3 {
            out.push(3);
            zeros = 0;
        }
        zeros = if b == 0 { zeros + 1 } else { 0 };
        out.push(b);
    }
}

struct BitReader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl BitReader<'_> {
    fn bit(&mut self) -> Result<u32, H264StreamError> {
        let byte = self
            .bytes
            .get(self.pos / 8)
            .ok_or("an H.264 header ends early")?;
        let b = (byte >> (7 - self.pos % 8)) & 1;
        self.pos += 1;
        Ok(b as u32)
    }
    fn bits(&mut self, n: u32) -> Result<u32, H264StreamError> {
        let mut v = 0;
        for _ in 0..n {
            v = (v << 1) | self.bit()?;
        }
        Ok(v)
    }
    fn ue(&mut self) -> Result<u32, H264StreamError> {
        let mut zeros = 0;
        while self.bit()? == 0 {
            zeros += 1;
            if zeros > 31 {
                return Err(H264StreamError::from(
                    "an H.264 Exp-Golomb code is longer than 32 bits",
                ));
            }
        }
        Ok(((1u64 << zeros) - 1 + self.bits(zeros)? as u64) as u32)
    }
    fn se(&mut self) -> Result<i32, H264StreamError> {
        let k = self.ue()? as i64;
        Ok(if k % 2 == 1 { (k + 1) / 2 } else { -(k / 2) } as i32)
    }
}

#[derive(Default)]
struct BitWriter {
    bytes: Vec<u8>,
    bit_len: usize,
}

impl BitWriter {
    fn bits(&mut self, value: u32, n: u32) {
        for i in (0..n).rev() {
            if self.bit_len.is_multiple_of(8) {
                self.bytes.push(0);
            }
            let b = ((value >> i) & 1) as u8;
            *self.bytes.last_mut().expect("pushed above") |= b << (7 - self.bit_len % 8);
            self.bit_len += 1;
        }
    }
    fn ue(&mut self, value: u32) {
        let v = value as u64 + 1;
        let len = 64 - v.leading_zeros();
        self.bits(0, len - 1);
        for i in (0..len).rev() {
            self.bits(((v >> i) & 1) as u32, 1);
        }
    }
    fn se(&mut self, value: i32) {
        let k = if value > 0 {
            2 * value as i64 - 1
        } else {
            -2 * value as i64
        };
        self.ue(k as u32);
    }
    /// rbsp_trailing_bits: a stop bit, then zeros to the byte boundary.
    fn trailing_bits(&mut self) {
        self.bits(1, 1);
        while !self.bit_len.is_multiple_of(8) {
            self.bits(0, 1);
        }
    }
}

fn read_bits_at(bytes: &[u8], at: usize, n: u32) -> u32 {
    let mut r = BitReader { bytes, pos: at };
    r.bits(n).unwrap_or(u32::MAX)
}

fn write_bits_at(bytes: &mut [u8], at: usize, n: u32, value: u32) {
    for i in 0..n as usize {
        let pos = at + i;
        let b = ((value >> (n as usize - 1 - i)) & 1) as u8;
        let mask = 1u8 << (7 - pos % 8);
        bytes[pos / 8] = (bytes[pos / 8] & !mask) | (b * mask);
    }
}

/// The bit offset of `frame_num` in a slice header's RBSP (after the NAL header byte).
fn frame_num_position(rbsp: &[u8]) -> Result<usize, H264StreamError> {
    let mut r = BitReader {
        bytes: rbsp,
        pos: 0,
    };
    r.ue()?; // first_mb_in_slice
    r.ue()?; // slice_type
    r.ue()?; // pic_parameter_set_id
    Ok(r.pos)
}

/// The fields of a sequence parameter set (§7.3.2.1.1) the repeats rely on, checked.
fn parse_sps(rbsp: &[u8]) -> Result<SpsFields, H264StreamError> {
    let mut r = BitReader {
        bytes: rbsp,
        pos: 0,
    };
    let profile_idc = r.bits(8)?;
    r.bits(16)?; // constraint flags, level_idc
    let sps_id = r.ue()?;
    if [100, 110, 122, 244, 44, 83, 86, 118, 128, 138, 139, 134, 135].contains(&profile_idc) {
        let chroma_format_idc = r.ue()?;
        if chroma_format_idc == 3 && r.bit()? == 1 {
            return Err(H264StreamError::from(
                "H.264 repeats: separate colour planes are not supported",
            ));
        }
        r.ue()?; // bit_depth_luma_minus8
        r.ue()?; // bit_depth_chroma_minus8
        r.bit()?; // qpprime_y_zero_transform_bypass_flag
        if r.bit()? == 1 {
            // seq_scaling_matrix_present_flag: skip the lists (§7.3.2.1.1.1).
            let lists = if chroma_format_idc == 3 { 12 } else { 8 };
            for i in 0..lists {
                if r.bit()? == 1 {
                    let size = if i < 6 { 16 } else { 64 };
                    let (mut last, mut next) = (8i32, 8i32);
                    for _ in 0..size {
                        if next != 0 {
                            next = (last + r.se()? + 256) % 256;
                        }
                        last = if next == 0 { last } else { next };
                    }
                }
            }
        }
    }
    let log2_max_frame_num = r.ue()?.saturating_add(4);
    if log2_max_frame_num > 16 {
        return Err(H264StreamError::from(format!(
            "the H.264 SPS gives log2_max_frame_num {log2_max_frame_num} (at most 16)"
        )));
    }
    let poc_type = r.ue()?;
    if poc_type != 2 {
        return Err(H264StreamError::from(format!(
            "H.264 repeats need picture order count type 2 (output order = decoding order); \
             the encoder wrote type {poc_type}"
        )));
    }
    let max_num_ref_frames = r.ue()?;
    if max_num_ref_frames != 1 {
        return Err(H264StreamError::from(format!(
            "H.264 repeats need a stream with one reference frame; the encoder's has \
             {max_num_ref_frames}"
        )));
    }
    r.bit()?; // gaps_in_frame_num_value_allowed_flag
    let width_mbs = r.ue()?.saturating_add(1);
    let height_map_units = r.ue()?.saturating_add(1);
    let pic_size_in_mbs = width_mbs
        .checked_mul(height_map_units)
        .filter(|&mbs| mbs <= 1 << 20)
        .ok_or_else(|| {
            H264StreamError(format!(
                "the H.264 SPS gives a picture of {width_mbs} × {height_map_units} macroblocks"
            ))
        })?;
    if r.bit()? != 1 {
        return Err(H264StreamError::from(
            "H.264 repeats need frame (not field) coding",
        ));
    }
    Ok(SpsFields {
        sps_id,
        log2_max_frame_num,
        pic_size_in_mbs,
    })
}

/// The fields of a picture parameter set (§7.3.2.2) the repeats rely on, checked.
fn parse_pps(rbsp: &[u8], sps: &SpsFields) -> Result<StreamParams, H264StreamError> {
    let mut r = BitReader {
        bytes: rbsp,
        pos: 0,
    };
    let pps_id = r.ue()?;
    let sps_id = r.ue()?;
    if sps_id != sps.sps_id {
        return Err(H264StreamError::from(format!(
            "the H.264 picture parameter set names SPS {sps_id}, the stream has SPS {}",
            sps.sps_id
        )));
    }
    if r.bit()? != 0 {
        return Err(H264StreamError::from(
            "H.264 repeats are written in CAVLC; the encoder chose CABAC",
        ));
    }
    r.bit()?; // bottom_field_pic_order_in_frame_present_flag
    if r.ue()? != 0 {
        return Err(H264StreamError::from(
            "H.264 repeats do not support slice groups",
        ));
    }
    r.ue()?; // num_ref_idx_l0_default_active_minus1 (overridden in the repeat)
    r.ue()?; // num_ref_idx_l1_default_active_minus1
    if r.bit()? != 0 {
        return Err(H264StreamError::from(
            "H.264 repeats do not support weighted prediction",
        ));
    }
    r.bits(2)?; // weighted_bipred_idc
    r.se()?; // pic_init_qp_minus26
    r.se()?; // pic_init_qs_minus26
    r.se()?; // chroma_qp_index_offset
    let deblocking_filter_control_present = r.bit()? == 1;
    r.bit()?; // constrained_intra_pred_flag
    if r.bit()? != 0 {
        return Err(H264StreamError::from(
            "H.264 repeats do not support redundant pictures",
        ));
    }
    Ok(StreamParams {
        log2_max_frame_num: sps.log2_max_frame_num,
        pic_size_in_mbs: sps.pic_size_in_mbs,
        pps_id,
        deblocking_filter_control_present,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn exp_golomb_codes_read_back_as_written() {
        let values = [0u32, 1, 2, 3, 7, 8, 255, 6_889, 65_535, 1 << 20];
        let signed = [0i32, 1, -1, 2, -2, 26, -26, 100_000, -100_000];
        let mut w = BitWriter::default();
        for &v in &values {
            w.ue(v);
        }
        for &v in &signed {
            w.se(v);
        }
        w.bits(0b101, 3);
        let mut r = BitReader {
            bytes: &w.bytes,
            pos: 0,
        };
        for &v in &values {
            assert_eq!(r.ue().unwrap(), v);
        }
        for &v in &signed {
            assert_eq!(r.se().unwrap(), v);
        }
        assert_eq!(r.bits(3).unwrap(), 0b101);
        // ue(0) is the single bit 1; ue(3) is 00100.
        let mut w = BitWriter::default();
        w.ue(0);
        w.ue(3);
        w.bits(0, 2);
        assert_eq!(w.bytes, vec![0b1001_0000]);
    }

    #[test]
    fn escaping_hides_start_codes_and_unescaping_undoes_it() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let (mut escaped, mut back) = (Vec::new(), Vec::new());
        for len in 0..400 {
            // Mostly zeros and small values, where start-code emulation happens.
            let rbsp: Vec<u8> = (0..len)
                .map(|_| match rng.random_range(0..4) {
                    0 | 1 => 0,
                    2 => rng.random_range(0..4),
                    _ => rng.random(),
                })
                .chain(std::iter::once(0x80)) // an RBSP ends in its stop bit
                .collect();
            escaped.clear();
            escape(&rbsp, &mut escaped);
            for w in escaped.windows(3) {
                assert!(
                    !(w[0] == 0 && w[1] == 0 && w[2] <= 2),
                    "{w:?} in {escaped:?}"
                );
            }
            unescape(&escaped, &mut back);
            assert_eq!(back, rbsp, "{rbsp:?}");
        }
    }

    proptest::proptest! {
        /// Whatever bytes arrive (a corrupted or foreign stream), the reader answers with a
        /// value or an error, never a panic.
        #[test]
        fn renumbering_arbitrary_bytes_never_panics(
            units in proptest::collection::vec(
                (proptest::sample::select(vec![0x67u8, 0x68, 0x65, 0x41, 0x01, 0x06]),
                 proptest::collection::vec(proptest::prelude::any::<u8>(), 0..24)),
                0..6),
        ) {
            let mut stream = Vec::new();
            for (header, payload) in &units {
                stream.extend_from_slice(&[0, 0, 0, 1, *header]);
                stream.extend_from_slice(payload);
            }
            let mut writer = RepeatWriter::new();
            let mut out = Vec::new();
            let _ = writer.renumber(&stream, &mut out);
            let _ = writer.repeat(&mut out);
            let _ = writer.renumber(&stream, &mut out);
        }
    }

    /// A valid SPS and PPS of the kind the repeats accept (Annex B), for the property test.
    fn parameter_sets() -> Vec<u8> {
        let mut sps = BitWriter::default();
        sps.bits(66, 8); // profile: baseline
        sps.bits(0, 8);
        sps.bits(40, 8);
        sps.ue(0);
        sps.ue(11); // log2_max_frame_num 15
        sps.ue(2); // picture order count type 2
        sps.ue(1); // one reference frame
        sps.bits(0, 1);
        sps.ue(5);
        sps.ue(3);
        sps.bits(1, 1); // frames only
        sps.bits(0, 3); // direct 8x8, cropping, VUI
        sps.trailing_bits();
        let mut pps = BitWriter::default();
        pps.ue(0);
        pps.ue(0);
        pps.bits(0, 2); // CAVLC, no bottom-field order
        pps.ue(0);
        pps.ue(0);
        pps.ue(0);
        pps.bits(0, 3);
        pps.se(0);
        pps.se(0);
        pps.se(0);
        pps.bits(0b100, 3); // deblocking control present
        pps.trailing_bits();
        let mut out = vec![0, 0, 0, 1, 0x67];
        escape(&sps.bytes, &mut out);
        out.extend_from_slice(&[0, 0, 0, 1, 0x68]);
        escape(&pps.bytes, &mut out);
        out
    }

    proptest::proptest! {
        /// Valid parameter sets, then slices of arbitrary bytes: errors, never a panic, and
        /// a repeat after an accepted IDR slice is a well-formed unit.
        #[test]
        fn arbitrary_slices_after_valid_parameter_sets_never_panic(
            slices in proptest::collection::vec(
                (proptest::sample::select(vec![0x65u8, 0x41, 0x01, 0x21]),
                 proptest::collection::vec(proptest::prelude::any::<u8>(), 0..16)),
                1..5),
        ) {
            let mut writer = RepeatWriter::new();
            let mut out = Vec::new();
            let only_sets = writer.renumber(&parameter_sets(), &mut out).unwrap_err();
            proptest::prop_assert!(only_sets.0.contains("holds no picture"), "{}", only_sets);
            for (header, payload) in &slices {
                let mut unit = vec![0, 0, 0, 1, *header];
                unit.extend_from_slice(payload);
                out.clear();
                if writer.renumber(&unit, &mut out).is_ok() {
                    out.clear();
                    writer.repeat(&mut out).unwrap();
                    proptest::prop_assert_eq!(&out[..5], &[0, 0, 0, 1, (header & 0x60) | 1][..]);
                }
            }
        }
    }

    #[test]
    fn nal_units_are_found_between_three_and_four_byte_start_codes() {
        let stream = [
            0, 0, 0, 1, 0x67, 1, 2, 0, 0, 1, 0x68, 3, 0, 0, 0, 1, 0x65, 0, 4,
        ];
        let units: Vec<&[u8]> = nal_units(&stream).collect();
        assert_eq!(
            units,
            vec![&[0x67, 1, 2][..], &[0x68, 3][..], &[0x65, 0, 4][..]]
        );
    }
}
