//! The telecommands' authentication trailer (TMTC interface, in the manner of CCSDS
//! SDLS authentication): the last 20 bytes of a telecommand's application data are a
//! 4-byte anti-replay sequence number (unsigned, big-endian) and HMAC-SHA-256 truncated to
//! 16 bytes, over every byte of the packet from its primary header through that sequence
//! number. The key is 32 bytes, 64 hexadecimal characters on one line of a key file that
//! only its owner may read. Checking a trailer touches no heap and compares the MAC in
//! constant time; whether the sequence number is fresh is `replay`'s to say.

use super::packet::{self, EncodeError, Tc, TcHeader, CRC_LEN, PRIMARY_LEN, TC_SECONDARY_LEN};
use hmac::digest::KeyInit;
use hmac::{Hmac, Mac};
use sha2::Sha256;
use std::io::{Read, Write};
use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};

/// Bytes of the key.
pub const KEY_LEN: usize = 32;
/// Bytes of the anti-replay sequence number.
pub const SEQ_LEN: usize = 4;
/// Bytes of the truncated MAC.
pub const MAC_LEN: usize = 16;
/// Bytes of the trailer.
pub const TRAILER_LEN: usize = SEQ_LEN + MAC_LEN;

type HmacSha256 = Hmac<Sha256>;
/// SHA-256's block: HMAC pads a shorter key with zeros to it (RFC 2104).
const BLOCK: usize = 64;

/// HMAC-SHA-256 keyed with a key of one block (a shorter key zero-padded, as HMAC does).
fn keyed(block_key: &[u8; BLOCK]) -> HmacSha256 {
    <HmacSha256 as KeyInit>::new(block_key.into())
}

/// The link's key. Its `Debug` shows no byte of it.
#[derive(Clone, PartialEq, Eq)]
pub struct Key([u8; KEY_LEN]);

impl std::fmt::Debug for Key {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Key(..)")
    }
}

/// Why a key file was refused.
#[derive(Debug, thiserror::Error)]
pub enum KeyError {
    #[error("key file {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("key file {path} is readable by group or others (mode {mode:04o}): chmod 600 it")]
    Exposed { path: PathBuf, mode: u32 },
    #[error("key file {path} is not a regular file")]
    NotAFile { path: PathBuf },
    #[error("a key is 64 hexadecimal characters on one line: {0}")]
    Malformed(&'static str),
}

impl Key {
    pub fn from_bytes(bytes: [u8; KEY_LEN]) -> Key {
        Key(bytes)
    }

    /// The key of a key file's text: 64 hexadecimal characters, then at most a line end.
    pub fn from_hex(text: &str) -> Result<Key, KeyError> {
        let line = text.strip_suffix('\n').unwrap_or(text);
        let line = line.strip_suffix('\r').unwrap_or(line);
        if line.len() != 2 * KEY_LEN {
            return Err(KeyError::Malformed("not 64 characters"));
        }
        let mut k = [0u8; KEY_LEN];
        for (i, pair) in line.as_bytes().chunks(2).enumerate() {
            let digit = |c: u8| {
                char::from(c)
                    .to_digit(16)
                    .ok_or(KeyError::Malformed("not hexadecimal"))
            };
            k[i] = (digit(pair[0])? * 16 + digit(pair[1])?) as u8;
        }
        Ok(Key(k))
    }

    /// The key as a key file holds it (without its line end).
    pub fn to_hex(&self) -> String {
        self.0.iter().map(|b| format!("{b:02x}")).collect()
    }

    /// Reads a key file, refusing one that group or others may read.
    pub fn load(path: &Path) -> Result<Key, KeyError> {
        let io = |source| KeyError::Io {
            path: path.to_path_buf(),
            source,
        };
        let meta = std::fs::metadata(path).map_err(io)?;
        if !meta.is_file() {
            return Err(KeyError::NotAFile {
                path: path.to_path_buf(),
            });
        }
        let mode = meta.permissions().mode() & 0o7777;
        if mode & 0o077 != 0 {
            return Err(KeyError::Exposed {
                path: path.to_path_buf(),
                mode,
            });
        }
        let mut text = String::new();
        // A key file is one line: reading more than a few lines' worth is refused.
        let f = std::fs::File::open(path).map_err(io)?;
        f.take(256)
            .read_to_string(&mut text)
            .map_err(|_| KeyError::Malformed("not text"))?;
        Key::from_hex(&text)
    }

    /// Makes a new random key and writes it to a new file of mode 0600 (an existing
    /// file is left alone: an error).
    pub fn create(path: &Path) -> Result<Key, KeyError> {
        let io = |source| KeyError::Io {
            path: path.to_path_buf(),
            source,
        };
        let mut k = [0u8; KEY_LEN];
        std::fs::File::open("/dev/urandom")
            .and_then(|mut r| r.read_exact(&mut k))
            .map_err(|source| KeyError::Io {
                path: "/dev/urandom".into(),
                source,
            })?;
        let key = Key(k);
        // Written whole to a temporary file, then linked in: a reader never finds the
        // key file empty or half written, and an existing file is never replaced.
        let mut tmp = path.as_os_str().to_owned();
        tmp.push(format!(".tmp-{}", std::process::id()));
        let tmp = std::path::PathBuf::from(tmp);
        let _ = std::fs::remove_file(&tmp);
        let written = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .mode(0o600)
            .open(&tmp)
            .and_then(|mut f| {
                writeln!(f, "{}", key.to_hex())?;
                f.sync_all()
            })
            .and_then(|_| std::fs::hard_link(&tmp, path));
        let _ = std::fs::remove_file(&tmp);
        written.map_err(io)?;
        Ok(key)
    }

    fn hmac(&self) -> HmacSha256 {
        let mut block = [0u8; BLOCK];
        block[..KEY_LEN].copy_from_slice(&self.0);
        keyed(&block)
    }

    /// The truncated MAC of `covered`.
    pub fn mac(&self, covered: &[u8]) -> [u8; MAC_LEN] {
        let mut m = self.hmac();
        m.update(covered);
        let full = m.finalize().into_bytes();
        let mut t = [0u8; MAC_LEN];
        t.copy_from_slice(&full[..MAC_LEN]);
        t
    }
}

/// Why a telecommand's trailer was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum AuthError {
    #[error("{len} bytes of application data cannot hold the 20-byte authentication trailer")]
    NoTrailer { len: usize },
    #[error("the authentication code does not match")]
    BadMac,
}

/// A telecommand whose MAC matched.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Authenticated<'a> {
    /// The anti-replay sequence number (still to be checked for freshness).
    pub seq: u32,
    /// The application data before the trailer.
    pub app_data: &'a [u8],
}

/// Checks a decoded telecommand's MAC (in constant time).
pub fn verify<'a>(key: &Key, tc: &Tc<'a>) -> Result<Authenticated<'a>, AuthError> {
    let n = tc.app_data.len();
    if n < TRAILER_LEN {
        return Err(AuthError::NoTrailer { len: n });
    }
    let (app_data, trailer) = tc.app_data.split_at(n - TRAILER_LEN);
    let (seq, tag) = trailer.split_at(SEQ_LEN);
    let covered = &tc.packet[..tc.packet.len() - CRC_LEN - MAC_LEN];
    let mut m = key.hmac();
    m.update(covered);
    m.verify_truncated_left(tag)
        .map_err(|_| AuthError::BadMac)?;
    Ok(Authenticated {
        seq: u32::from_be_bytes([seq[0], seq[1], seq[2], seq[3]]),
        app_data,
    })
}

/// Writes a telecommand carrying `app_data` and a trailer of `seq` and its MAC under
/// `key` into `out`; returns the packet's length.
pub fn encode_signed_tc(
    out: &mut [u8],
    h: &TcHeader,
    app_data: &[u8],
    seq: u32,
    key: &Key,
) -> Result<usize, EncodeError> {
    const AT: usize = PRIMARY_LEN + TC_SECONDARY_LEN;
    packet::encode_tc_with(out, h, app_data.len() + TRAILER_LEN, |p| {
        let end = AT + app_data.len();
        p[AT..end].copy_from_slice(app_data);
        p[end..end + SEQ_LEN].copy_from_slice(&seq.to_be_bytes());
        let tag = key.mac(&p[..end + SEQ_LEN]);
        p[end + SEQ_LEN..].copy_from_slice(&tag);
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ground::packet::decode_tc;

    fn hex(s: &str) -> Vec<u8> {
        (0..s.len())
            .step_by(2)
            .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
            .collect()
    }

    #[test]
    fn rfc_4231_test_case_2() {
        // Key "Jefe", data "what do ya want for nothing?", zero-padded to the block as HMAC does.
        let mut block = [0u8; BLOCK];
        block[..4].copy_from_slice(b"Jefe");
        let mut m = keyed(&block);
        m.update(b"what do ya want for nothing?");
        let want = hex("5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843");
        assert_eq!(m.finalize().into_bytes().as_slice(), want);
    }

    fn key() -> Key {
        Key::from_hex(&"0123456789abcdef".repeat(4)).unwrap()
    }

    fn header() -> TcHeader {
        TcHeader {
            apid: 0x120,
            sequence_count: 1,
            ack_flags: 0xF,
            service: 8,
            subtype: 1,
            source_id: 7,
        }
    }

    #[test]
    fn a_signed_telecommand_verifies_and_any_flipped_bit_does_not() {
        let mut out = [0u8; 128];
        let n = encode_signed_tc(&mut out, &header(), &[0, 2], 41, &key()).unwrap();
        let p = &out[..n];
        assert_eq!(n, 6 + 5 + 2 + 20 + 2);
        assert_eq!(p[13..17], 41u32.to_be_bytes());
        assert_eq!(p[17..33], key().mac(&p[..17]));
        let tc = decode_tc(p, 0x120).unwrap();
        assert_eq!(
            verify(&key(), &tc),
            Ok(Authenticated {
                seq: 41,
                app_data: &[0, 2]
            })
        );
        let other = Key::from_bytes([7; KEY_LEN]);
        assert_eq!(verify(&other, &tc), Err(AuthError::BadMac));
        // Every bit of the covered bytes and of the tag counts (the CRC resealed each time).
        for bit in 0..(n - CRC_LEN) * 8 {
            let mut q = p.to_vec();
            q[bit / 8] ^= 1 << (bit % 8);
            let c = crate::ground::crc::crc16(&q[..n - 2]);
            q[n - 2..].copy_from_slice(&c.to_be_bytes());
            if let Ok(tc) = decode_tc(&q, 0x120) {
                assert!(verify(&key(), &tc).is_err(), "bit {bit}");
            }
        }
        let mut short = [0u8; 64];
        let n = packet::encode_tc(&mut short, &header(), &[0; 19]).unwrap();
        let tc = decode_tc(&short[..n], 0x120).unwrap();
        assert_eq!(verify(&key(), &tc), Err(AuthError::NoTrailer { len: 19 }));
    }

    #[test]
    fn key_text_is_64_hex_characters_on_one_line() {
        let text = "00".repeat(31) + "ff";
        assert_eq!(
            Key::from_hex(&(text.clone() + "\n")).unwrap(),
            Key::from_hex(&text).unwrap()
        );
        assert!(matches!(
            Key::from_hex(&text[..62]),
            Err(KeyError::Malformed(_))
        ));
        assert!(matches!(
            Key::from_hex(&(text.clone() + "\n\n")),
            Err(KeyError::Malformed(_))
        ));
        assert!(matches!(
            Key::from_hex(&("zz".to_string() + &text[2..])),
            Err(KeyError::Malformed(_))
        ));
        assert!(matches!(
            Key::from_hex(&("é".to_string() + &text[2..])),
            Err(KeyError::Malformed(_))
        ));
        assert_eq!(key().to_hex(), "0123456789abcdef".repeat(4));
        assert_eq!(format!("{:?}", key()), "Key(..)");
    }

    #[test]
    fn a_key_file_others_can_read_is_refused() {
        let dir = std::env::temp_dir().join(format!("taiji-key-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("ground.key");
        let made = Key::create(&path).unwrap();
        let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o600);
        assert_eq!(Key::load(&path).unwrap(), made);
        assert!(
            matches!(Key::create(&path), Err(KeyError::Io { .. })),
            "an existing key is kept"
        );
        for m in [0o640, 0o604, 0o660] {
            std::fs::set_permissions(&path, std::fs::Permissions::from_mode(m)).unwrap();
            assert!(matches!(Key::load(&path), Err(KeyError::Exposed { mode, .. }) if mode == m));
        }
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o400)).unwrap();
        assert_eq!(Key::load(&path).unwrap(), made);
        assert!(matches!(Key::load(&dir), Err(KeyError::NotAFile { .. })));
        assert!(matches!(
            Key::load(&dir.join("none")),
            Err(KeyError::Io { .. })
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
