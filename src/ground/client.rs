//! The ground side of the link: a UDP socket that sends authenticated telecommands to
//! the onboard set and receives the telemetry it sends back. Telemetry goes only to
//! the sender of the last accepted telecommand, so the socket that sends is the one
//! that listens. Sequence numbers come from the key's counter file (`seq`) unless given.

use super::auth::{self, Key, KeyError};
use super::dictionary::APID;
use super::packet::{TcHeader, MAX_PACKET_LEN, MAX_SEQUENCE_COUNT};
use super::seq::{self, SeqError};
use std::net::{SocketAddr, UdpSocket};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Where the onboard set listens by default.
pub const DEFAULT_ADDR: &str = "127.0.0.1:7301";
/// The source ID the ground tools put in their telecommands.
pub const SOURCE_ID: u16 = 1;
/// Acknowledgement flags: acceptance, start, progress, completion (bits 0 to 3).
pub const ACK_ACCEPTANCE: u8 = 0b0001;
pub const ACK_START: u8 = 0b0010;
pub const ACK_PROGRESS: u8 = 0b0100;
pub const ACK_COMPLETION: u8 = 0b1000;
pub const ACK_ALL: u8 = 0b1111;

/// Why the link could not be set up or used.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    #[error("--key: {0}")]
    Key(#[from] KeyError),
    #[error("--seq: {0}")]
    Seq(#[from] SeqError),
    #[error("--bind {addr}: {source}")]
    Bind {
        addr: SocketAddr,
        source: std::io::Error,
    },
    #[error("--to {addr}: {source}")]
    Connect {
        addr: SocketAddr,
        source: std::io::Error,
    },
    #[error("sending to {addr}: {source}")]
    Send {
        addr: SocketAddr,
        source: std::io::Error,
    },
    #[error("receiving from {addr}: {source}")]
    Receive {
        addr: SocketAddr,
        source: std::io::Error,
    },
    #[error("the telecommand does not fit a packet: {0}")]
    Encode(#[from] super::packet::EncodeError),
}

/// How the link is set up.
#[derive(Debug, Clone)]
pub struct LinkConfig {
    pub to: SocketAddr,
    /// Local address (None: `default_bind`).
    pub bind: Option<SocketAddr>,
    pub key: PathBuf,
    /// A sequence number to use for the first telecommand instead of the counter's.
    pub seq: Option<u32>,
}

/// A telecommand as sent.
#[derive(Debug, Clone)]
pub struct Sent {
    /// Its first 4 bytes: the request ID its verification reports carry.
    pub request_id: [u8; 4],
    /// The anti-replay sequence number it carries.
    pub seq: u32,
    pub service: u8,
    pub subtype: u8,
    pub ack_flags: u8,
    /// The whole packet.
    pub packet: Vec<u8>,
}

/// What a receive found.
#[derive(Debug)]
pub enum Received {
    /// A datagram (one packet, as received).
    Datagram(Vec<u8>),
    /// Nothing within the wait.
    Nothing,
    /// The onboard address refused a datagram (ICMP port unreachable): nothing listens.
    Refused,
}

/// The ground end of the link.
pub struct Link {
    socket: UdpSocket,
    to: SocketAddr,
    key: Key,
    counter: PathBuf,
    /// The number given for the next telecommand (`--seq`), used once.
    given: Option<u32>,
    buf: Vec<u8>,
}

impl Link {
    /// Loads the key (refusing one others may read), binds the socket and connects it
    /// to the onboard address (so that only its datagrams are received).
    pub fn open(cfg: &LinkConfig) -> Result<Link, ClientError> {
        let key = Key::load(&cfg.key)?;
        let bind = cfg.bind.unwrap_or_else(|| default_bind(cfg.to));
        let socket =
            UdpSocket::bind(bind).map_err(|source| ClientError::Bind { addr: bind, source })?;
        socket
            .connect(cfg.to)
            .map_err(|source| ClientError::Connect {
                addr: cfg.to,
                source,
            })?;
        Ok(Link {
            socket,
            to: cfg.to,
            key,
            counter: seq::counter_path(&cfg.key),
            given: cfg.seq,
            buf: vec![0; MAX_PACKET_LEN],
        })
    }

    pub fn to(&self) -> SocketAddr {
        self.to
    }

    /// The socket's local address (where the telemetry comes to).
    pub fn local(&self) -> Option<SocketAddr> {
        self.socket.local_addr().ok()
    }

    /// The counter file the sequence numbers come from.
    pub fn counter(&self) -> &Path {
        &self.counter
    }

    /// Signs and sends telecommand (`service`, `subtype`) with `app_data` (before the
    /// trailer), asking for the reports in `ack_flags`.
    pub fn send(
        &mut self,
        service: u8,
        subtype: u8,
        ack_flags: u8,
        app_data: &[u8],
    ) -> Result<Sent, ClientError> {
        let seq = seq::take(&self.counter, self.given.take())?;
        let h = TcHeader {
            apid: APID,
            // The packet's sequence count follows the anti-replay number (modulo 2¹⁴), so
            // each telecommand's request ID differs from the last ones'.
            sequence_count: (seq & u32::from(MAX_SEQUENCE_COUNT)) as u16,
            ack_flags,
            service,
            subtype,
            source_id: SOURCE_ID,
        };
        let mut out = vec![0u8; MAX_PACKET_LEN];
        let n = auth::encode_signed_tc(&mut out, &h, app_data, seq, &self.key)?;
        out.truncate(n);
        self.socket.send(&out).map_err(|source| ClientError::Send {
            addr: self.to,
            source,
        })?;
        Ok(Sent {
            request_id: [out[0], out[1], out[2], out[3]],
            seq,
            service,
            subtype,
            ack_flags,
            packet: out,
        })
    }

    /// Waits up to `wait` (at least 1 ms) for a datagram.
    pub fn receive(&mut self, wait: Duration) -> Result<Received, ClientError> {
        let wait = wait.max(Duration::from_millis(1));
        self.socket
            .set_read_timeout(Some(wait))
            .map_err(|source| ClientError::Receive {
                addr: self.to,
                source,
            })?;
        match self.socket.recv(&mut self.buf) {
            Ok(n) => Ok(Received::Datagram(self.buf[..n].to_vec())),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::Interrupted
                ) =>
            {
                Ok(Received::Nothing)
            }
            Err(e) if e.kind() == std::io::ErrorKind::ConnectionRefused => Ok(Received::Refused),
            Err(source) => Err(ClientError::Receive {
                addr: self.to,
                source,
            }),
        }
    }

    /// Receives until `deadline` or the first datagram.
    pub fn receive_until(&mut self, deadline: Instant) -> Result<Received, ClientError> {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Ok(Received::Nothing);
        }
        self.receive(left)
    }
}

/// An ephemeral port on the loopback of `to`'s address family when `to` is a loopback
/// address, else on every interface (the system picks the route).
pub fn default_bind(to: SocketAddr) -> SocketAddr {
    let loopback = to.ip().is_loopback();
    match to {
        SocketAddr::V4(_) if loopback => SocketAddr::from(([127, 0, 0, 1], 0)),
        SocketAddr::V4(_) => SocketAddr::from(([0, 0, 0, 0], 0)),
        SocketAddr::V6(_) if loopback => SocketAddr::from((std::net::Ipv6Addr::LOCALHOST, 0)),
        SocketAddr::V6(_) => SocketAddr::from((std::net::Ipv6Addr::UNSPECIFIED, 0)),
    }
}

/// Records of a saved telemetry stream (`listen --save`): each packet as received,
/// prefixed by its length in bytes as a u32, big-endian. Appending whole records keeps
/// a file that several runs appended to readable.
pub mod saved {
    use std::io::Write;

    /// Why a saved stream does not read back.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
    pub enum SavedError {
        #[error("the stream ends inside a record's length at byte {at}")]
        ShortLength { at: usize },
        #[error("the record at byte {at} says {len} bytes, {left} are left")]
        ShortRecord { at: usize, len: usize, left: usize },
    }

    /// Writes one record.
    pub fn write(w: &mut impl Write, packet: &[u8]) -> std::io::Result<()> {
        let n = u32::try_from(packet.len()).map_err(|_| std::io::ErrorKind::InvalidInput)?;
        let mut rec = Vec::with_capacity(4 + packet.len());
        rec.extend_from_slice(&n.to_be_bytes());
        rec.extend_from_slice(packet);
        w.write_all(&rec)
    }

    /// The packets of a saved stream's whole records, in order, and why the bytes
    /// after them do not read (None: there are none).
    pub fn read(bytes: &[u8]) -> (Vec<&[u8]>, Option<SavedError>) {
        let mut out = Vec::new();
        let mut at = 0;
        while at < bytes.len() {
            let Some(n) = bytes[at..].first_chunk::<4>() else {
                return (out, Some(SavedError::ShortLength { at }));
            };
            let len = u32::from_be_bytes(*n) as usize;
            let left = bytes.len() - at - 4;
            if len > left {
                return (out, Some(SavedError::ShortRecord { at, len, left }));
            }
            out.push(&bytes[at + 4..at + 4 + len]);
            at += 4 + len;
        }
        (out, None)
    }
}

static TERMINATED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

extern "C" fn on_termination(_: libc::c_int) {
    TERMINATED.store(true, std::sync::atomic::Ordering::SeqCst);
}

/// Takes SIGINT and SIGTERM from now on: they set a flag (`terminated`) instead of
/// ending the process, and interrupt a waiting receive.
pub fn catch_termination() {
    for sig in [libc::SIGINT, libc::SIGTERM] {
        // SAFETY: the handler only stores to an atomic; the structure is zeroed, then
        // filled, before the call, and outlives it.
        unsafe {
            let mut sa: libc::sigaction = std::mem::zeroed();
            sa.sa_sigaction = on_termination as extern "C" fn(libc::c_int) as usize;
            libc::sigemptyset(&mut sa.sa_mask);
            sa.sa_flags = 0;
            libc::sigaction(sig, &sa, std::ptr::null_mut());
        }
    }
}

/// Has SIGINT or SIGTERM come since `catch_termination`?
pub fn terminated() -> bool {
    TERMINATED.load(std::sync::atomic::Ordering::SeqCst)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_saved_stream_reads_back_record_by_record() {
        let mut buf = Vec::new();
        saved::write(&mut buf, &[1, 2, 3]).unwrap();
        saved::write(&mut buf, &[]).unwrap();
        saved::write(&mut buf, &[9]).unwrap();
        assert_eq!(buf[..7], [0, 0, 0, 3, 1, 2, 3]);
        let (recs, err) = saved::read(&buf);
        assert_eq!(recs, [&[1u8, 2, 3][..], &[], &[9]]);
        assert_eq!(err, None);
        let (recs, err) = saved::read(&buf[..buf.len() - 1]);
        assert_eq!(recs.len(), 2);
        assert_eq!(
            err,
            Some(saved::SavedError::ShortRecord {
                at: 11,
                len: 1,
                left: 0
            })
        );
        assert_eq!(
            saved::read(&buf[..2]),
            (vec![], Some(saved::SavedError::ShortLength { at: 0 }))
        );
    }

    #[test]
    fn the_default_local_address_is_loopback_for_a_loopback_set() {
        let b = default_bind("127.0.0.1:7301".parse().unwrap());
        assert!(b.ip().is_loopback() && b.port() == 0);
        let b = default_bind("[::1]:7301".parse().unwrap());
        assert!(b.ip().is_loopback() && b.is_ipv6());
        assert!(default_bind("10.0.0.1:7301".parse().unwrap())
            .ip()
            .is_unspecified());
    }
}
