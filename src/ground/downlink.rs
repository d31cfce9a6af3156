//! The onboard side's telemetry writer: packets of the calibration application written
//! into a fixed outbox (allocated once, at construction), each with the next sequence
//! count (14 bits, per APID) and its message type's counter (16 bits, per service and
//! subtype), as PUS-C wants. The TMTC process sends the outbox and clears it.

use super::dictionary::APID;
use super::packet::{
    encode_tm_with, CdsShort, TmHeader, CRC_LEN, MAX_SEQUENCE_COUNT, PRIMARY_LEN, TM_SECONDARY_LEN,
};

/// The longest source data the set sends: a 20,2 report of 255 parameters of 8 bytes.
pub const MAX_SOURCE_DATA: usize = 1 + 255 * (2 + 8);
/// The longest telemetry packet the set sends.
pub const TM_MAX: usize = PRIMARY_LEN + TM_SECONDARY_LEN + MAX_SOURCE_DATA + CRC_LEN;
/// Packets the outbox holds between two sends.
pub const OUTBOX: usize = 32;

/// The message types the set sends, for their counters.
const TM_TYPES: [(u8, u8); 13] = [
    (1, 1),
    (1, 2),
    (1, 3),
    (1, 4),
    (1, 7),
    (1, 8),
    (3, 25),
    (5, 1),
    (5, 2),
    (5, 3),
    (5, 4),
    (17, 2),
    (20, 2),
];

/// The outbox and the counters.
pub struct Downlink {
    bufs: Box<[[u8; TM_MAX]]>,
    lens: [usize; OUTBOX],
    n: usize,
    seq: u16,
    counters: [u16; TM_TYPES.len()],
    /// Packets not written: the outbox was full.
    pub dropped: u32,
}

impl Default for Downlink {
    fn default() -> Self {
        Downlink::new()
    }
}

impl Downlink {
    pub fn new() -> Downlink {
        Downlink {
            bufs: vec![[0u8; TM_MAX]; OUTBOX].into_boxed_slice(),
            lens: [0; OUTBOX],
            n: 0,
            seq: 0,
            counters: [0; TM_TYPES.len()],
            dropped: 0,
        }
    }

    /// Writes a packet (`service`, `subtype`) with `data_len` bytes of source data that
    /// `fill` writes; false when it did not fit (counted in `dropped`).
    pub fn push(
        &mut self,
        service: u8,
        subtype: u8,
        destination_id: u16,
        time: CdsShort,
        data_len: usize,
        fill: impl FnOnce(&mut [u8]),
    ) -> bool {
        let ty = TM_TYPES
            .iter()
            .position(|&t| t == (service, subtype))
            .unwrap_or(0);
        if self.n == OUTBOX {
            self.dropped = self.dropped.wrapping_add(1);
            return false;
        }
        let h = TmHeader {
            apid: APID,
            sequence_count: self.seq,
            service,
            subtype,
            message_counter: self.counters[ty],
            destination_id,
            time,
        };
        match encode_tm_with(&mut self.bufs[self.n], &h, data_len, fill) {
            Ok(len) => {
                self.lens[self.n] = len;
                self.n += 1;
                self.seq = (self.seq + 1) & MAX_SEQUENCE_COUNT;
                self.counters[ty] = self.counters[ty].wrapping_add(1);
                true
            }
            Err(_) => {
                self.dropped = self.dropped.wrapping_add(1);
                false
            }
        }
    }

    /// Packets waiting.
    pub fn len(&self) -> usize {
        self.n
    }

    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Packet `i` of those waiting.
    pub fn packet(&self, i: usize) -> Option<&[u8]> {
        (i < self.n).then(|| &self.bufs[i][..self.lens[i]])
    }

    /// Empties the outbox.
    pub fn clear(&mut self) {
        self.n = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ground::packet::decode_tm;

    #[test]
    fn packets_count_per_apid_and_per_message_type() {
        let mut d = Downlink::new();
        assert!(d.push(17, 2, 5, CdsShort::default(), 0, |_| {}));
        assert!(d.push(1, 1, 5, CdsShort::default(), 4, |b| b.fill(7)));
        assert!(d.push(17, 2, 5, CdsShort::default(), 0, |_| {}));
        assert_eq!(d.len(), 3);
        let t = decode_tm(d.packet(2).unwrap(), APID).unwrap();
        assert_eq!((t.header.sequence_count, t.header.message_counter), (2, 1));
        let t = decode_tm(d.packet(1).unwrap(), APID).unwrap();
        assert_eq!(
            (t.source_data, t.header.message_counter),
            (&[7u8; 4][..], 0)
        );
        assert!(d.packet(3).is_none());
        d.clear();
        for _ in 0..OUTBOX {
            assert!(d.push(17, 2, 5, CdsShort::default(), 0, |_| {}));
        }
        assert!(!d.push(17, 2, 5, CdsShort::default(), 0, |_| {}));
        assert_eq!(d.dropped, 1);
        d.clear();
        assert!(d.push(20, 2, 5, CdsShort::default(), MAX_SOURCE_DATA, |_| {}));
        assert_eq!(d.packet(0).unwrap().len(), TM_MAX);
        assert!(!d.push(20, 2, 5, CdsShort::default(), MAX_SOURCE_DATA + 1, |_| {}));
    }
}
