//! CCSDS 133.0-B-2 space packets carrying PUS-C (ECSS-E-ST-70-41C) secondary headers,
//! as the TMTC interface fixes them: version 0, secondary header flag set, unsegmented,
//! CRC-16/CCITT-FALSE packet error control. Encoding writes into the caller's buffer and
//! decoding borrows from it: neither touches the heap.
//!
//! | part | bytes | fields |
//! |---|---|---|
//! | primary header | 6 | version (3 bits), type (1), secondary header flag (1), APID (11); sequence flags (2), count (14); data length − 1 (16) |
//! | TC secondary header | 5 | PUS version 2 (4 bits), acknowledgement flags (4); service; subtype; source ID (16) |
//! | TM secondary header | 14 | PUS version 2 (4 bits), time reference status 0 (4); service; subtype; message type counter (16); destination ID (16); CDS short time (7) |
//! | packet error control | 2 | CRC-16/CCITT-FALSE of every byte before it |

use super::crc::crc16;

/// Bytes of the primary header.
pub const PRIMARY_LEN: usize = 6;
/// Bytes of the PUS-C telecommand secondary header.
pub const TC_SECONDARY_LEN: usize = 5;
/// Bytes of the CCSDS CDS short time code: its preamble field, 16-bit day, 32-bit
/// millisecond of day.
pub const CDS_LEN: usize = 7;
/// The CDS time code's preamble field: CDS, epoch 1958-01-01, 16-bit day, no
/// sub-millisecond field (CCSDS 301.0-B-4, 3.3).
pub const CDS_P_FIELD: u8 = 0x40;
/// Bytes of the PUS-C telemetry secondary header, its time included.
pub const TM_SECONDARY_LEN: usize = 7 + CDS_LEN;
/// Bytes of the packet error control.
pub const CRC_LEN: usize = 2;
/// The longest space packet: the primary header and 65536 bytes of data field.
pub const MAX_PACKET_LEN: usize = PRIMARY_LEN + 65536;
/// The PUS version of PUS-C.
pub const PUS_VERSION: u8 = 2;
/// Sequence flags of an unsegmented packet.
pub const UNSEGMENTED: u8 = 0b11;
/// The largest APID (11 bits).
pub const MAX_APID: u16 = 0x7FF;
/// The largest sequence count (14 bits): counts run modulo 2¹⁴.
pub const MAX_SEQUENCE_COUNT: u16 = 0x3FFF;

/// The packet type bit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PacketType {
    Tm = 0,
    Tc = 1,
}

/// The primary header's fields.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PrimaryHeader {
    pub version: u8,
    pub packet_type: PacketType,
    pub secondary_header: bool,
    pub apid: u16,
    pub sequence_flags: u8,
    pub sequence_count: u16,
    /// The packet data length field: bytes of the data field minus one.
    pub data_length: u16,
}

impl PrimaryHeader {
    /// The fields of the first 6 bytes of a packet.
    pub fn read(b: &[u8; PRIMARY_LEN]) -> PrimaryHeader {
        let id = u16::from_be_bytes([b[0], b[1]]);
        let seq = u16::from_be_bytes([b[2], b[3]]);
        PrimaryHeader {
            version: (id >> 13) as u8,
            packet_type: if id & 0x1000 != 0 {
                PacketType::Tc
            } else {
                PacketType::Tm
            },
            secondary_header: id & 0x0800 != 0,
            apid: id & MAX_APID,
            sequence_flags: (seq >> 14) as u8,
            sequence_count: seq & MAX_SEQUENCE_COUNT,
            data_length: u16::from_be_bytes([b[4], b[5]]),
        }
    }

    /// The packet's whole length as its data length field says.
    pub fn packet_len(&self) -> usize {
        PRIMARY_LEN + usize::from(self.data_length) + 1
    }
}

/// Why bytes are not a packet of ours: one variant per class of bad input, each with
/// its failure code in the dictionary (`dictionary::Failure::from`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum PacketError {
    #[error("truncated: {len} bytes, where the shortest packet of the type has {min}")]
    Truncated { len: usize, min: usize },
    #[error(
        "the packet data length field says {declared} bytes of packet, the datagram has {actual}"
    )]
    LengthMismatch { declared: usize, actual: usize },
    #[error("packet version number {0}, not 0")]
    WrongVersion(u8),
    #[error("packet type {found:?} where {expected:?} is expected")]
    WrongType {
        expected: PacketType,
        found: PacketType,
    },
    #[error("the secondary header flag is not set")]
    NoSecondaryHeader,
    #[error("sequence flags {0:#04b}, not 0b11 (unsegmented)")]
    Segmented(u8),
    #[error("packet error control {found:#06x}, where the bytes give {computed:#06x}")]
    BadCrc { found: u16, computed: u16 },
    #[error("APID {0:#05x} is not the calibration application's")]
    UnknownApid(u16),
    #[error("PUS version {0}, not 2 (PUS-C)")]
    WrongPusVersion(u8),
}

/// Why a packet could not be written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EncodeError {
    #[error("the packet needs {need} bytes, the buffer has {have}")]
    BufferTooSmall { need: usize, have: usize },
    #[error("{len} bytes of data do not fit a space packet")]
    DataTooLong { len: usize },
    #[error("{field} {value} is out of its range")]
    FieldOutOfRange { field: &'static str, value: u32 },
}

/// A time as a CCSDS CDS short time code (CCSDS 301.0-B-4): its preamble field, days
/// since the epoch and milliseconds of the day. The set's simulated clock, with its epoch in the dictionary.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CdsShort {
    pub day: u16,
    pub ms_of_day: u32,
}

impl CdsShort {
    const MS_PER_DAY: i64 = 86_400_000;

    /// The time `ns` after the epoch, to the millisecond below (before the epoch: the
    /// epoch; past day 65535: the last millisecond of that day).
    pub fn from_ns(ns: i64) -> CdsShort {
        let ms = ns.max(0) / 1_000_000;
        let day = ms / Self::MS_PER_DAY;
        if day > i64::from(u16::MAX) {
            return CdsShort {
                day: u16::MAX,
                ms_of_day: (Self::MS_PER_DAY - 1) as u32,
            };
        }
        CdsShort {
            day: day as u16,
            ms_of_day: (ms % Self::MS_PER_DAY) as u32,
        }
    }

    /// Nanoseconds after the epoch.
    pub fn to_ns(self) -> i64 {
        (i64::from(self.day) * Self::MS_PER_DAY + i64::from(self.ms_of_day)) * 1_000_000
    }

    pub fn to_bytes(self) -> [u8; CDS_LEN] {
        let mut b = [CDS_P_FIELD; CDS_LEN];
        b[1..3].copy_from_slice(&self.day.to_be_bytes());
        b[3..].copy_from_slice(&self.ms_of_day.to_be_bytes());
        b
    }

    /// The time of a time code (its preamble field is not read).
    pub fn from_bytes(b: &[u8; CDS_LEN]) -> CdsShort {
        CdsShort {
            day: u16::from_be_bytes([b[1], b[2]]),
            ms_of_day: u32::from_be_bytes([b[3], b[4], b[5], b[6]]),
        }
    }
}

/// What a telecommand's headers say besides its length.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TcHeader {
    pub apid: u16,
    pub sequence_count: u16,
    /// Acceptance, start, progress and completion reports asked for: bits 0, 1, 2, 3.
    pub ack_flags: u8,
    pub service: u8,
    pub subtype: u8,
    pub source_id: u16,
}

/// What a telemetry packet's headers say besides its length.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TmHeader {
    pub apid: u16,
    pub sequence_count: u16,
    pub service: u8,
    pub subtype: u8,
    pub message_counter: u16,
    pub destination_id: u16,
    pub time: CdsShort,
}

/// A decoded telecommand, borrowing the datagram.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tc<'a> {
    pub header: TcHeader,
    /// The application data (the authentication trailer included).
    pub app_data: &'a [u8],
    /// The whole packet, its packet error control included.
    pub packet: &'a [u8],
}

/// A decoded telemetry packet, borrowing the datagram.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tm<'a> {
    pub header: TmHeader,
    pub source_data: &'a [u8],
    pub packet: &'a [u8],
}

/// The checks every packet passes, in order: long enough, version, type, secondary
/// header flag, unsegmented, the length field, the CRC, the APID, the PUS version.
fn check(
    bytes: &[u8],
    ty: PacketType,
    secondary_len: usize,
    apid: u16,
) -> Result<PrimaryHeader, PacketError> {
    let min = PRIMARY_LEN + secondary_len + CRC_LEN;
    let Some(first) = bytes
        .first_chunk::<PRIMARY_LEN>()
        .filter(|_| bytes.len() >= min)
    else {
        return Err(PacketError::Truncated {
            len: bytes.len(),
            min,
        });
    };
    let h = PrimaryHeader::read(first);
    if h.version != 0 {
        return Err(PacketError::WrongVersion(h.version));
    }
    if h.packet_type != ty {
        return Err(PacketError::WrongType {
            expected: ty,
            found: h.packet_type,
        });
    }
    if !h.secondary_header {
        return Err(PacketError::NoSecondaryHeader);
    }
    if h.sequence_flags != UNSEGMENTED {
        return Err(PacketError::Segmented(h.sequence_flags));
    }
    if h.packet_len() != bytes.len() {
        return Err(PacketError::LengthMismatch {
            declared: h.packet_len(),
            actual: bytes.len(),
        });
    }
    let (body, pec) = bytes.split_at(bytes.len() - CRC_LEN);
    let (found, computed) = (u16::from_be_bytes([pec[0], pec[1]]), crc16(body));
    if found != computed {
        return Err(PacketError::BadCrc { found, computed });
    }
    if h.apid != apid {
        return Err(PacketError::UnknownApid(h.apid));
    }
    let pus = bytes[PRIMARY_LEN] >> 4;
    if pus != PUS_VERSION {
        return Err(PacketError::WrongPusVersion(pus));
    }
    Ok(h)
}

/// Decodes a telecommand of application `apid` (one datagram: one whole packet).
pub fn decode_tc(bytes: &[u8], apid: u16) -> Result<Tc<'_>, PacketError> {
    let h = check(bytes, PacketType::Tc, TC_SECONDARY_LEN, apid)?;
    let s = &bytes[PRIMARY_LEN..];
    Ok(Tc {
        header: TcHeader {
            apid: h.apid,
            sequence_count: h.sequence_count,
            ack_flags: s[0] & 0x0F,
            service: s[1],
            subtype: s[2],
            source_id: u16::from_be_bytes([s[3], s[4]]),
        },
        app_data: &bytes[PRIMARY_LEN + TC_SECONDARY_LEN..bytes.len() - CRC_LEN],
        packet: bytes,
    })
}

/// Decodes a telemetry packet of application `apid`.
pub fn decode_tm(bytes: &[u8], apid: u16) -> Result<Tm<'_>, PacketError> {
    let h = check(bytes, PacketType::Tm, TM_SECONDARY_LEN, apid)?;
    let s = &bytes[PRIMARY_LEN..];
    let mut time = [0u8; CDS_LEN];
    time.copy_from_slice(&s[7..7 + CDS_LEN]);
    Ok(Tm {
        header: TmHeader {
            apid: h.apid,
            sequence_count: h.sequence_count,
            service: s[1],
            subtype: s[2],
            message_counter: u16::from_be_bytes([s[3], s[4]]),
            destination_id: u16::from_be_bytes([s[5], s[6]]),
            time: CdsShort::from_bytes(&time),
        },
        source_data: &bytes[PRIMARY_LEN + TM_SECONDARY_LEN..bytes.len() - CRC_LEN],
        packet: bytes,
    })
}

/// Writes the primary header of a packet with `user_len` bytes after its secondary
/// header; returns the packet's whole length.
fn write_primary(
    out: &mut [u8],
    ty: PacketType,
    apid: u16,
    count: u16,
    secondary_len: usize,
    user_len: usize,
) -> Result<usize, EncodeError> {
    if apid > MAX_APID {
        return Err(EncodeError::FieldOutOfRange {
            field: "APID",
            value: apid.into(),
        });
    }
    if count > MAX_SEQUENCE_COUNT {
        return Err(EncodeError::FieldOutOfRange {
            field: "sequence count",
            value: count.into(),
        });
    }
    let data_field = secondary_len + user_len + CRC_LEN;
    let Ok(data_length) = u16::try_from(data_field - 1) else {
        return Err(EncodeError::DataTooLong { len: user_len });
    };
    let need = PRIMARY_LEN + data_field;
    if out.len() < need {
        return Err(EncodeError::BufferTooSmall {
            need,
            have: out.len(),
        });
    }
    let id = (ty as u16) << 12 | 0x0800 | apid;
    out[..2].copy_from_slice(&id.to_be_bytes());
    out[2..4].copy_from_slice(&(u16::from(UNSEGMENTED) << 14 | count).to_be_bytes());
    out[4..6].copy_from_slice(&data_length.to_be_bytes());
    Ok(need)
}

/// Writes the packet error control into the last 2 bytes of `packet`.
fn seal(packet: &mut [u8]) {
    let n = packet.len() - CRC_LEN;
    let c = crc16(&packet[..n]);
    packet[n..].copy_from_slice(&c.to_be_bytes());
}

/// Writes a telecommand with `app_len` bytes of application data into `out`: the
/// headers, then `fill` with the packet up to its CRC (the application data start at
/// `PRIMARY_LEN + TC_SECONDARY_LEN`), then the CRC. Returns the packet's length.
pub fn encode_tc_with(
    out: &mut [u8],
    h: &TcHeader,
    app_len: usize,
    fill: impl FnOnce(&mut [u8]),
) -> Result<usize, EncodeError> {
    if h.ack_flags > 0x0F {
        return Err(EncodeError::FieldOutOfRange {
            field: "acknowledgement flags",
            value: h.ack_flags.into(),
        });
    }
    let n = write_primary(
        out,
        PacketType::Tc,
        h.apid,
        h.sequence_count,
        TC_SECONDARY_LEN,
        app_len,
    )?;
    let s = &mut out[PRIMARY_LEN..PRIMARY_LEN + TC_SECONDARY_LEN];
    s[0] = PUS_VERSION << 4 | h.ack_flags;
    s[1] = h.service;
    s[2] = h.subtype;
    s[3..5].copy_from_slice(&h.source_id.to_be_bytes());
    fill(&mut out[..n - CRC_LEN]);
    seal(&mut out[..n]);
    Ok(n)
}

/// Writes a telecommand carrying `app_data` (its trailer included) into `out`.
pub fn encode_tc(out: &mut [u8], h: &TcHeader, app_data: &[u8]) -> Result<usize, EncodeError> {
    const AT: usize = PRIMARY_LEN + TC_SECONDARY_LEN;
    encode_tc_with(out, h, app_data.len(), |p| {
        p[AT..].copy_from_slice(app_data)
    })
}

/// Writes a telemetry packet with `data_len` bytes of source data into `out`, `fill`
/// writing the source data. Returns the packet's length.
pub fn encode_tm_with(
    out: &mut [u8],
    h: &TmHeader,
    data_len: usize,
    fill: impl FnOnce(&mut [u8]),
) -> Result<usize, EncodeError> {
    let n = write_primary(
        out,
        PacketType::Tm,
        h.apid,
        h.sequence_count,
        TM_SECONDARY_LEN,
        data_len,
    )?;
    let s = &mut out[PRIMARY_LEN..PRIMARY_LEN + TM_SECONDARY_LEN];
    s[0] = PUS_VERSION << 4; // time reference status 0
    s[1] = h.service;
    s[2] = h.subtype;
    s[3..5].copy_from_slice(&h.message_counter.to_be_bytes());
    s[5..7].copy_from_slice(&h.destination_id.to_be_bytes());
    s[7..].copy_from_slice(&h.time.to_bytes());
    fill(&mut out[PRIMARY_LEN + TM_SECONDARY_LEN..n - CRC_LEN]);
    seal(&mut out[..n]);
    Ok(n)
}

/// Writes a telemetry packet carrying `source_data` into `out`.
pub fn encode_tm(out: &mut [u8], h: &TmHeader, source_data: &[u8]) -> Result<usize, EncodeError> {
    encode_tm_with(out, h, source_data.len(), |d| {
        d.copy_from_slice(source_data)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const APID: u16 = 0x120;

    fn hex(s: &str) -> Vec<u8> {
        (0..s.len())
            .step_by(2)
            .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
            .collect()
    }

    fn tc_header() -> TcHeader {
        TcHeader {
            apid: APID,
            sequence_count: 3,
            ack_flags: 0xF,
            service: 17,
            subtype: 1,
            source_id: 0x42,
        }
    }

    fn tm_header() -> TmHeader {
        TmHeader {
            apid: APID,
            sequence_count: 5,
            service: 3,
            subtype: 25,
            message_counter: 7,
            destination_id: 9,
            time: CdsShort {
                day: 0x0102,
                ms_of_day: 0x0304_0506,
            },
        }
    }

    #[test]
    fn a_telecommand_byte_by_byte() {
        let mut out = [0u8; 64];
        let n = encode_tc(&mut out, &tc_header(), &[1, 2]).unwrap();
        let p = &out[..n];
        // Version 0, type 1 (TC), secondary header flag 1, APID 0x120.
        assert_eq!(p[..2], [0b0001_1001, 0x20]);
        // Sequence flags 0b11, count 3.
        assert_eq!(p[2..4], [0b1100_0000, 3]);
        // Data field: 5 + 2 + 2 bytes, the field says 9 − 1.
        assert_eq!(p[4..6], [0, 8]);
        // PUS version 2, all four acknowledgement flags; service 17, subtype 1; source 0x0042.
        assert_eq!(p[6..11], [0x2F, 17, 1, 0x00, 0x42]);
        assert_eq!(p[11..13], [1, 2]);
        assert_eq!(crate::ground::crc::crc16(&p[..13]).to_be_bytes(), p[13..]);
        // The same packet as the Python spacepackets package builds it.
        assert_eq!(p, hex("1920c00300082f1101004201020d9f"));
        let tc = decode_tc(p, APID).unwrap();
        assert_eq!((tc.header, tc.app_data), (tc_header(), &[1u8, 2][..]));
    }

    #[test]
    fn a_telemetry_packet_byte_by_byte() {
        let mut out = [0u8; 64];
        let n = encode_tm(&mut out, &tm_header(), &[0xAA, 0xBB]).unwrap();
        let p = &out[..n];
        // Version 0, type 0 (TM), secondary header flag 1, APID 0x120.
        assert_eq!(p[..2], [0b0000_1001, 0x20]);
        assert_eq!(p[2..4], [0b1100_0000, 5]);
        // Data field: 14 + 2 + 2 bytes.
        assert_eq!(p[4..6], [0, 17]);
        // PUS version 2, time reference status 0; service 3, subtype 25; counter 7; destination 9.
        assert_eq!(p[6..13], [0x20, 3, 25, 0, 7, 0, 9]);
        // CDS short: preamble 0x40, day 0x0102, millisecond of day 0x03040506.
        assert_eq!(p[13..20], [0x40, 1, 2, 3, 4, 5, 6]);
        assert_eq!(p[20..22], [0xAA, 0xBB]);
        // The same packet as the Python spacepackets package builds it.
        assert_eq!(
            p,
            hex("0920c00500112003190007000940010203040506aabbe567"),
            "{p:02x?}"
        );
        let tm = decode_tm(p, APID).unwrap();
        assert_eq!(
            (tm.header, tm.source_data),
            (tm_header(), &[0xAAu8, 0xBB][..])
        );
    }

    #[test]
    fn every_bad_input_class_has_its_error() {
        let mut out = [0u8; 64];
        let n = encode_tc(&mut out, &tc_header(), &[1, 2, 3]).unwrap();
        let good = out[..n].to_vec();
        let resealed = |f: &dyn Fn(&mut Vec<u8>)| {
            let mut p = good.clone();
            f(&mut p);
            let k = p.len() - CRC_LEN;
            let c = crate::ground::crc::crc16(&p[..k]);
            p[k..].copy_from_slice(&c.to_be_bytes());
            p
        };
        let err = |p: &[u8]| decode_tc(p, APID).unwrap_err();
        assert_eq!(err(&good[..5]), PacketError::Truncated { len: 5, min: 13 });
        assert_eq!(
            err(&good[..12]),
            PacketError::Truncated { len: 12, min: 13 }
        );
        assert_eq!(
            err(&good[..n - 1]),
            PacketError::LengthMismatch {
                declared: n,
                actual: n - 1
            }
        );
        let mut long = good.clone();
        long.push(0);
        assert_eq!(
            err(&long),
            PacketError::LengthMismatch {
                declared: n,
                actual: n + 1
            }
        );
        assert_eq!(
            err(&resealed(&|p| p[0] |= 0x20)),
            PacketError::WrongVersion(1)
        );
        let want = PacketError::WrongType {
            expected: PacketType::Tc,
            found: PacketType::Tm,
        };
        assert_eq!(err(&resealed(&|p| p[0] &= !0x10)), want);
        assert_eq!(
            err(&resealed(&|p| p[0] &= !0x08)),
            PacketError::NoSecondaryHeader
        );
        assert_eq!(err(&resealed(&|p| p[2] &= 0x7F)), PacketError::Segmented(1));
        let mut bad = good.clone();
        bad[12] ^= 1;
        assert!(matches!(err(&bad), PacketError::BadCrc { .. }));
        assert_eq!(
            err(&resealed(&|p| p[1] = 0x21)),
            PacketError::UnknownApid(0x121)
        );
        assert_eq!(
            err(&resealed(&|p| p[6] = 0x1F)),
            PacketError::WrongPusVersion(1)
        );
        assert!(matches!(
            decode_tm(&good, APID),
            Err(PacketError::Truncated { .. } | PacketError::WrongType { .. })
        ));
    }

    #[test]
    fn encoding_refuses_what_does_not_fit() {
        let mut small = [0u8; 14];
        let want = EncodeError::BufferTooSmall { need: 15, have: 14 };
        assert_eq!(encode_tc(&mut small, &tc_header(), &[1, 2]), Err(want));
        let h = TcHeader {
            apid: 0x800,
            ..tc_header()
        };
        assert!(matches!(
            encode_tc(&mut [0; 64], &h, &[]),
            Err(EncodeError::FieldOutOfRange { .. })
        ));
        let h = TcHeader {
            sequence_count: 0x4000,
            ..tc_header()
        };
        assert!(matches!(
            encode_tc(&mut [0; 64], &h, &[]),
            Err(EncodeError::FieldOutOfRange { .. })
        ));
        let big = vec![0u8; 65536];
        let mut out = vec![0u8; MAX_PACKET_LEN + 16];
        assert_eq!(
            encode_tm(&mut out, &tm_header(), &big),
            Err(EncodeError::DataTooLong { len: 65536 })
        );
        let most = &big[..65536 - TM_SECONDARY_LEN - CRC_LEN];
        assert_eq!(encode_tm(&mut out, &tm_header(), most), Ok(MAX_PACKET_LEN));
        assert!(decode_tm(&out[..MAX_PACKET_LEN], APID).is_ok());
    }

    #[test]
    fn cds_short_time_from_the_simulated_clock() {
        assert_eq!(CdsShort::from_ns(-5), CdsShort::default());
        let t = CdsShort::from_ns(86_400_000_000_000 + 1_500_999_999);
        assert_eq!(
            t,
            CdsShort {
                day: 1,
                ms_of_day: 1500
            }
        );
        assert_eq!(t.to_ns(), 86_401_500_000_000);
        assert_eq!(CdsShort::from_bytes(&t.to_bytes()), t);
        assert_eq!(CdsShort::from_ns(i64::MAX).day, u16::MAX);
    }
}
