//! The ground interface's definitions as data: the APID, the services and subtypes the
//! set serves, the functions of service 8 with their arguments, the failure codes of
//! every refusal and the set's modes. The decoders below read these tables, and the
//! published dictionary and docs/ground-packets.md are printed from them.

use super::auth::AuthError;
use super::packet::PacketError;
use super::replay::ReplayError;

/// APID of the calibration application, telecommands and telemetry.
pub const APID: u16 = 0x120;

/// The epoch of the telemetry's CDS time: the set's simulated clock, its time 0 at day 0,
/// millisecond 0.
pub const TIME_EPOCH: &str = "the campaign's simulated time 0 (day 0, millisecond 0); standby reports the time of the last campaign";

/// A field's type on the wire (big-endian).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    U8,
    U16,
    U32,
    U64,
    /// IEEE 754 binary64.
    F64,
}

impl Kind {
    /// Bytes on the wire.
    pub const fn size(self) -> usize {
        match self {
            Kind::U8 => 1,
            Kind::U16 => 2,
            Kind::U32 => 4,
            Kind::U64 | Kind::F64 => 8,
        }
    }

    pub const fn name(self) -> &'static str {
        match self {
            Kind::U8 => "u8",
            Kind::U16 => "u16",
            Kind::U32 => "u32",
            Kind::U64 => "u64",
            Kind::F64 => "f64",
        }
    }
}

/// A service and the subtypes the set takes (TC) and sends (TM).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Service {
    pub id: u8,
    pub name: &'static str,
    pub tc: &'static [u8],
    pub tm: &'static [u8],
}

/// The services (TMTC interface), each with its ECSS meaning.
pub const SERVICES: &[Service] = &[
    Service {
        id: 1,
        name: "request verification",
        tc: &[],
        tm: &[1, 2, 3, 4, 7, 8],
    },
    Service {
        id: 3,
        name: "housekeeping",
        tc: &[5, 6, 27, 31],
        tm: &[25],
    },
    Service {
        id: 5,
        name: "event reporting",
        tc: &[5, 6],
        tm: &[1, 2, 3, 4],
    },
    Service {
        id: 8,
        name: "function management",
        tc: &[1],
        tm: &[],
    },
    Service {
        id: 17,
        name: "test",
        tc: &[1],
        tm: &[2],
    },
    Service {
        id: 20,
        name: "parameter management",
        tc: &[1, 3],
        tm: &[2],
    },
];

/// Whether the set takes telecommand (`service`, `subtype`).
pub fn route(service: u8, subtype: u8) -> Result<&'static Service, Failure> {
    let s = SERVICES
        .iter()
        .find(|s| s.id == service)
        .ok_or(Failure::UnknownService)?;
    if s.tc.contains(&subtype) {
        Ok(s)
    } else {
        Err(Failure::UnknownSubtype)
    }
}

/// An argument of a function.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arg {
    pub name: &'static str,
    pub kind: Kind,
    pub unit: &'static str,
    /// Inclusive range of a floating-point argument (a non-finite value is out of range).
    pub range: Option<(f64, f64)>,
    pub meaning: &'static str,
}

/// A function of service 8 (8,1: function ID, then its arguments).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FunctionDef {
    pub id: u16,
    pub name: &'static str,
    pub args: &'static [Arg],
    pub meaning: &'static str,
}

/// The functions (their IDs and arguments are fixed by the TMTC interface).
pub const FUNCTIONS: &[FunctionDef] = &[
    FunctionDef {
        id: 1,
        name: "start_campaign",
        args: &[
            Arg {
                name: "seed",
                kind: Kind::U64,
                unit: "",
                range: None,
                meaning: "the campaign's random seed",
            },
            Arg {
                name: "duration",
                kind: Kind::F64,
                unit: "s",
                range: Some((0.0, f64::MAX)),
                meaning: "the campaign's length; 0: the scenario's",
            },
        ],
        meaning: "start a campaign",
    },
    FunctionDef {
        id: 2,
        name: "stop_campaign",
        args: &[],
        meaning: "stop the campaign",
    },
    FunctionDef {
        id: 3,
        name: "apply_result",
        args: &[],
        meaning: "apply the last campaign's result to the onboard calibration table",
    },
    FunctionDef {
        id: 4,
        name: "restore_table",
        args: &[],
        meaning: "restore the table's previous values",
    },
    FunctionDef {
        id: 5,
        name: "shutdown",
        args: &[],
        meaning: "shut the set down",
    },
];

/// A function call, decoded and range-checked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Function {
    Start { seed: u64, duration_s: f64 },
    Stop,
    Apply,
    Restore,
    Shutdown,
}

/// Arguments a function has at most.
const MAX_ARGS: usize = 4;

/// Reads a big-endian field of `kind` (`bytes` has its size): integers as their value,
/// binary64 as its bits.
pub fn read_bits(kind: Kind, bytes: &[u8]) -> u64 {
    bytes[..kind.size()]
        .iter()
        .fold(0u64, |v, &b| v << 8 | u64::from(b))
}

/// Writes `bits` (as `read_bits` gives them) as a big-endian field of `kind` into the
/// start of `out` (which has its size).
pub fn write_bits(kind: Kind, bits: u64, out: &mut [u8]) {
    let n = kind.size();
    out[..n].copy_from_slice(&bits.to_be_bytes()[8 - n..]);
}

/// A field's value as a number: an integer's value, binary64 from its bits.
pub fn value_f64(kind: Kind, bits: u64) -> f64 {
    match kind {
        Kind::F64 => f64::from_bits(bits),
        _ => bits as f64,
    }
}

/// A field's value as text: an integer in decimal, binary64 as Rust prints it (the
/// shortest text that reads back to the same bits).
pub fn format_value(kind: Kind, bits: u64) -> String {
    match kind {
        Kind::F64 => format!("{:?}", f64::from_bits(bits)),
        _ => bits.to_string(),
    }
}

/// Decodes 8,1's application data (before the trailer): the function ID and its
/// arguments, each checked against its range.
pub fn parse_function(app_data: &[u8]) -> Result<Function, Failure> {
    let (Some(id), rest) = (
        app_data.first_chunk::<2>(),
        app_data.get(2..).unwrap_or_default(),
    ) else {
        return Err(Failure::BadLength);
    };
    let id = u16::from_be_bytes(*id);
    let def = FUNCTIONS
        .iter()
        .find(|f| f.id == id)
        .ok_or(Failure::UnknownFunction)?;
    if rest.len() != def.args.iter().map(|a| a.kind.size()).sum::<usize>() {
        return Err(Failure::BadLength);
    }
    let mut bits = [0u64; MAX_ARGS];
    let mut at = 0;
    for (slot, arg) in bits.iter_mut().zip(def.args) {
        *slot = read_bits(arg.kind, &rest[at..]);
        at += arg.kind.size();
        if let Some((lo, hi)) = arg.range {
            let v = f64::from_bits(*slot);
            if !(lo..=hi).contains(&v) {
                return Err(Failure::OutOfRange);
            }
        }
    }
    Ok(match id {
        1 => Function::Start {
            seed: bits[0],
            duration_s: f64::from_bits(bits[1]),
        },
        2 => Function::Stop,
        3 => Function::Apply,
        4 => Function::Restore,
        _ => Function::Shutdown,
    })
}

/// A list of 16-bit IDs as 3,27 and 20,1 carry them: N (u8), then N IDs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IdList<'a>(&'a [u8]);

impl<'a> IdList<'a> {
    /// The list in application data (before the trailer) that holds nothing else.
    pub fn parse(app_data: &'a [u8]) -> Result<IdList<'a>, Failure> {
        match app_data.split_first() {
            Some((&n, ids)) if ids.len() == 2 * usize::from(n) => Ok(IdList(ids)),
            _ => Err(Failure::BadLength),
        }
    }

    pub fn len(&self) -> usize {
        self.0.len() / 2
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    pub fn iter(&self) -> impl Iterator<Item = u16> + 'a {
        self.0
            .chunks_exact(2)
            .map(|c| u16::from_be_bytes([c[0], c[1]]))
    }
}

/// Bytes of a verification report's request ID: the telecommand's packet ID and
/// packet sequence control, its first 4 bytes.
pub const REQUEST_ID_LEN: usize = 4;

/// The source data of a verification report (service 1) on the datagram `tc`: the
/// request ID (the datagram's first 4 bytes, zero-padded when it is shorter), then, in a
/// failure report, the failure code (u16). Returns the bytes and how many are used.
pub fn verification_data(tc: &[u8], failure: Option<Failure>) -> ([u8; REQUEST_ID_LEN + 2], usize) {
    let mut d = [0u8; REQUEST_ID_LEN + 2];
    let n = tc.len().min(REQUEST_ID_LEN);
    d[..n].copy_from_slice(&tc[..n]);
    match failure {
        Some(f) => {
            d[REQUEST_ID_LEN..].copy_from_slice(&f.code().to_be_bytes());
            (d, REQUEST_ID_LEN + 2)
        }
        None => (d, REQUEST_ID_LEN),
    }
}

/// The set's mode, as housekeeping reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Mode {
    /// Up, no campaign running: waiting for function 1.
    Standby = 0,
    /// A campaign runs.
    Running = 1,
    /// Function 5 or SIGTERM: the set is ending.
    ShuttingDown = 2,
}

impl Mode {
    pub const ALL: [Mode; 3] = [Mode::Standby, Mode::Running, Mode::ShuttingDown];

    pub const fn name(self) -> &'static str {
        match self {
            Mode::Standby => "standby",
            Mode::Running => "running",
            Mode::ShuttingDown => "shutting_down",
        }
    }
}

/// How many failure codes there are (`Failure::ALL`).
pub const N_FAILURES: usize = 30;

/// Failure codes of a failed verification report (1,2 / 1,4 / 1,8): one per class of
/// refused telecommand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u16)]
pub enum Failure {
    BadCrc = 1,
    Truncated = 2,
    LengthMismatch = 3,
    WrongVersion = 4,
    WrongType = 5,
    NoSecondaryHeader = 6,
    Segmented = 7,
    UnknownApid = 8,
    WrongPusVersion = 9,
    NoTrailer = 10,
    BadMac = 11,
    Replayed = 12,
    UnknownService = 13,
    UnknownSubtype = 14,
    UnknownFunction = 15,
    UnknownParameter = 16,
    UnknownStructure = 17,
    UnknownEvent = 18,
    BadLength = 19,
    OutOfRange = 20,
    StartWhileRunning = 21,
    NotRunning = 22,
    NoResult = 23,
    UnverifiedResult = 24,
    PriorDominated = 25,
    NothingToRestore = 26,
    StateNotSaved = 27,
    ReadOnly = 28,
    TableNotSaved = 29,
    CampaignFailed = 30,
}

impl Failure {
    /// Every failure code, in order.
    pub const ALL: [Failure; N_FAILURES] = [
        Failure::BadCrc,
        Failure::Truncated,
        Failure::LengthMismatch,
        Failure::WrongVersion,
        Failure::WrongType,
        Failure::NoSecondaryHeader,
        Failure::Segmented,
        Failure::UnknownApid,
        Failure::WrongPusVersion,
        Failure::NoTrailer,
        Failure::BadMac,
        Failure::Replayed,
        Failure::UnknownService,
        Failure::UnknownSubtype,
        Failure::UnknownFunction,
        Failure::UnknownParameter,
        Failure::UnknownStructure,
        Failure::UnknownEvent,
        Failure::BadLength,
        Failure::OutOfRange,
        Failure::StartWhileRunning,
        Failure::NotRunning,
        Failure::NoResult,
        Failure::UnverifiedResult,
        Failure::PriorDominated,
        Failure::NothingToRestore,
        Failure::StateNotSaved,
        Failure::ReadOnly,
        Failure::TableNotSaved,
        Failure::CampaignFailed,
    ];

    /// The code on the wire.
    pub const fn code(self) -> u16 {
        self as u16
    }

    /// The code's failure, if it is one.
    pub fn from_code(code: u16) -> Option<Failure> {
        Failure::ALL.into_iter().find(|f| f.code() == code)
    }

    /// Its name and what it means.
    pub const fn describe(self) -> (&'static str, &'static str) {
        match self {
            Failure::BadCrc => (
                "bad_crc",
                "the packet error control does not match the packet's bytes",
            ),
            Failure::Truncated => (
                "truncated",
                "shorter than a primary header, a secondary header and a CRC",
            ),
            Failure::LengthMismatch => (
                "length_mismatch",
                "the packet data length field disagrees with the datagram's length",
            ),
            Failure::WrongVersion => ("wrong_version", "packet version number not 0"),
            Failure::WrongType => (
                "wrong_type",
                "a telemetry packet where a telecommand is expected",
            ),
            Failure::NoSecondaryHeader => (
                "no_secondary_header",
                "the secondary header flag is not set",
            ),
            Failure::Segmented => ("segmented", "sequence flags not 0b11 (unsegmented)"),
            Failure::UnknownApid => (
                "unknown_apid",
                "an APID other than the calibration application's",
            ),
            Failure::WrongPusVersion => ("wrong_pus_version", "PUS version not 2 (PUS-C)"),
            Failure::NoTrailer => (
                "no_trailer",
                "application data too short for the 20-byte authentication trailer",
            ),
            Failure::BadMac => (
                "bad_mac",
                "the authentication code does not match the packet and key",
            ),
            Failure::Replayed => (
                "replayed",
                "anti-replay sequence number not larger than the last accepted",
            ),
            Failure::UnknownService => ("unknown_service", "a service the set does not serve"),
            Failure::UnknownSubtype => ("unknown_subtype", "a subtype the service does not take"),
            Failure::UnknownFunction => ("unknown_function", "a function ID not in the dictionary"),
            Failure::UnknownParameter => {
                ("unknown_parameter", "a parameter ID not in the dictionary")
            }
            Failure::UnknownStructure => (
                "unknown_structure",
                "a housekeeping structure ID not in the dictionary",
            ),
            Failure::UnknownEvent => ("unknown_event", "an event ID not in the dictionary"),
            Failure::BadLength => (
                "bad_length",
                "application data of the wrong length for the request",
            ),
            Failure::OutOfRange => ("out_of_range", "an argument or value outside its range"),
            Failure::StartWhileRunning => {
                ("start_while_running", "function 1 while a campaign runs")
            }
            Failure::NotRunning => ("not_running", "function 2 with no campaign running"),
            Failure::NoResult => ("no_result", "function 3 before any campaign has ended"),
            Failure::UnverifiedResult => (
                "unverified_result",
                "function 3 on a result its report does not call verified (an unverifying status bit, or a non-finite or non-positive value or σ)",
            ),
            Failure::PriorDominated => (
                "prior_dominated",
                "function 3 on a result that its priors dominate",
            ),
            Failure::NothingToRestore => {
                ("nothing_to_restore", "function 4 with no previous table")
            }
            Failure::StateNotSaved => (
                "state_not_saved",
                "the anti-replay state could not be written: not executed",
            ),
            Failure::ReadOnly => ("read_only", "20,3 on a parameter that cannot be set"),
            Failure::TableNotSaved => (
                "table_not_saved",
                "the table could not be written: not applied",
            ),
            Failure::CampaignFailed => (
                "campaign_failed",
                "the campaign was refused or its process set failed (the supervisor's log says why)",
            ),
        }
    }

    pub const fn name(self) -> &'static str {
        self.describe().0
    }
}

impl From<PacketError> for Failure {
    fn from(e: PacketError) -> Failure {
        match e {
            PacketError::Truncated { .. } => Failure::Truncated,
            PacketError::LengthMismatch { .. } => Failure::LengthMismatch,
            PacketError::WrongVersion(_) => Failure::WrongVersion,
            PacketError::WrongType { .. } => Failure::WrongType,
            PacketError::NoSecondaryHeader => Failure::NoSecondaryHeader,
            PacketError::Segmented(_) => Failure::Segmented,
            PacketError::BadCrc { .. } => Failure::BadCrc,
            PacketError::UnknownApid(_) => Failure::UnknownApid,
            PacketError::WrongPusVersion(_) => Failure::WrongPusVersion,
        }
    }
}

impl From<AuthError> for Failure {
    fn from(e: AuthError) -> Failure {
        match e {
            AuthError::NoTrailer { .. } => Failure::NoTrailer,
            AuthError::BadMac => Failure::BadMac,
        }
    }
}

impl From<&ReplayError> for Failure {
    fn from(e: &ReplayError) -> Failure {
        match e {
            ReplayError::Replayed { .. } => Failure::Replayed,
            ReplayError::Io { .. } | ReplayError::Corrupt { .. } => Failure::StateNotSaved,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_failure_code_is_listed_once_in_order() {
        for (i, f) in Failure::ALL.into_iter().enumerate() {
            assert_eq!(usize::from(f.code()), i + 1);
            assert_eq!(Failure::from_code(f.code()), Some(f));
        }
        assert_eq!(Failure::from_code(0), None);
        let mut names: Vec<_> = Failure::ALL.iter().map(|f| f.name()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), Failure::ALL.len());
    }

    #[test]
    fn telecommands_are_routed_by_the_service_table() {
        assert_eq!(route(17, 1).map(|s| s.id), Ok(17));
        assert_eq!(route(8, 1).map(|s| s.name), Ok("function management"));
        assert_eq!(route(3, 25), Err(Failure::UnknownSubtype));
        assert_eq!(route(1, 1), Err(Failure::UnknownSubtype));
        assert_eq!(route(2, 1), Err(Failure::UnknownService));
        for s in SERVICES {
            for &t in s.tc {
                assert!(route(s.id, t).is_ok());
            }
        }
    }

    fn call(id: u16, args: &[u8]) -> Result<Function, Failure> {
        let mut a = id.to_be_bytes().to_vec();
        a.extend_from_slice(args);
        parse_function(&a)
    }

    #[test]
    fn functions_decode_with_their_arguments_range_checked() {
        let mut start = 42u64.to_be_bytes().to_vec();
        start.extend_from_slice(&600.5f64.to_be_bytes());
        assert_eq!(
            call(1, &start),
            Ok(Function::Start {
                seed: 42,
                duration_s: 600.5
            })
        );
        assert_eq!(call(1, &start[..15]), Err(Failure::BadLength));
        for bad in [-1.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            start[8..].copy_from_slice(&bad.to_be_bytes());
            assert_eq!(call(1, &start), Err(Failure::OutOfRange), "{bad}");
        }
        start[8..].copy_from_slice(&0f64.to_be_bytes());
        assert_eq!(
            call(1, &start),
            Ok(Function::Start {
                seed: 42,
                duration_s: 0.0
            })
        );
        assert_eq!(call(2, &[]), Ok(Function::Stop));
        assert_eq!(call(3, &[]), Ok(Function::Apply));
        assert_eq!(call(4, &[]), Ok(Function::Restore));
        assert_eq!(call(5, &[]), Ok(Function::Shutdown));
        assert_eq!(call(5, &[0]), Err(Failure::BadLength));
        assert_eq!(call(6, &[]), Err(Failure::UnknownFunction));
        assert_eq!(call(0, &[]), Err(Failure::UnknownFunction));
        assert_eq!(parse_function(&[0]), Err(Failure::BadLength));
        assert_eq!(parse_function(&[]), Err(Failure::BadLength));
        assert!(FUNCTIONS.iter().all(|f| f.args.len() <= MAX_ARGS));
    }

    #[test]
    fn verification_reports_name_the_request_and_the_failure() {
        let tc = [0x19, 0x20, 0xC0, 0x07, 0, 9];
        assert_eq!(
            verification_data(&tc, None),
            ([0x19, 0x20, 0xC0, 0x07, 0, 0], 4)
        );
        assert_eq!(
            verification_data(&tc, Some(Failure::BadMac)),
            ([0x19, 0x20, 0xC0, 0x07, 0, 11], 6)
        );
        assert_eq!(
            verification_data(&[0x19], Some(Failure::Truncated)),
            ([0x19, 0, 0, 0, 0, 2], 6)
        );
    }

    #[test]
    fn id_lists_hold_exactly_n_ids() {
        let l = IdList::parse(&[2, 0, 1, 0x01, 0x02]).unwrap();
        assert_eq!(l.iter().collect::<Vec<_>>(), [1, 0x0102]);
        assert_eq!(l.len(), 2);
        assert!(IdList::parse(&[0]).unwrap().is_empty());
        assert_eq!(IdList::parse(&[]), Err(Failure::BadLength));
        assert_eq!(IdList::parse(&[2, 0, 1]), Err(Failure::BadLength));
        assert_eq!(IdList::parse(&[1, 0, 1, 9]), Err(Failure::BadLength));
    }
}
