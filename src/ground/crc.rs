//! The packet error control of every packet (TMTC interface): CRC-16/CCITT-FALSE,
//! polynomial 0x1021, initial value 0xFFFF, no reflection, no final XOR.

/// The byte-wise table of the polynomial 0x1021, built at compile time.
const TABLE: [u16; 256] = {
    let mut t = [0u16; 256];
    let mut i = 0;
    while i < 256 {
        let mut c = (i as u16) << 8;
        let mut bit = 0;
        while bit < 8 {
            c = if c & 0x8000 != 0 {
                (c << 1) ^ 0x1021
            } else {
                c << 1
            };
            bit += 1;
        }
        t[i] = c;
        i += 1;
    }
    t
};

/// CRC-16/CCITT-FALSE of `bytes`.
pub fn crc16(bytes: &[u8]) -> u16 {
    bytes.iter().fold(0xFFFF, |c, &b| {
        (c << 8) ^ TABLE[usize::from((c >> 8) as u8 ^ b)]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_check_value_of_the_catalogue() {
        // The catalogue's check value: the CRC of the nine ASCII digits.
        assert_eq!(crc16(b"123456789"), 0x29B1);
        assert_eq!(crc16(b""), 0xFFFF);
    }

    #[test]
    fn a_packet_followed_by_its_crc_checks_to_zero() {
        let mut p = b"calibration".to_vec();
        let c = crc16(&p);
        p.extend_from_slice(&c.to_be_bytes());
        assert_eq!(crc16(&p), 0);
    }
}
