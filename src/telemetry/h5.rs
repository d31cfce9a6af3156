//! The few HDF5 structures `telemetry.h5` is made of, encoded byte by byte: a version-2
//! superblock, version-2 object headers, compact groups and attributes, contiguous
//! datasets and one global heap for the strings (HDF5 File Format Specification 3.0).
//!
//! Why not `hdf5-pure`'s writer: it builds a whole file in memory, and appends in place
//! only to rank-1 datasets, while the layout has N×3, N×4, N×I×3 and N×3×2 ones. Written
//! here, each dataset's contiguous storage is reserved up front, rows land in it a chunk
//! at a time, and the dataset's header is rewritten (same size) with the new row count:
//! the file is valid after every chunk.

/// HDF5's "undefined address".
pub const UNDEF: u64 = u64::MAX;

/// Element type of a dataset or attribute.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    F64,
    U64,
    U8,
}

impl Kind {
    pub fn size(self) -> usize {
        match self {
            Kind::F64 | Kind::U64 => 8,
            Kind::U8 => 1,
        }
    }

    /// Datatype message (little-endian IEEE double or unsigned integer).
    fn datatype(self) -> Vec<u8> {
        match self {
            Kind::F64 => {
                let mut v = vec![0x11, 0x20, 0x3f, 0x00];
                v.extend(8u32.to_le_bytes());
                v.extend([0, 0, 64, 0, 52, 11, 0, 52]);
                v.extend(1023u32.to_le_bytes());
                v
            }
            Kind::U64 | Kind::U8 => {
                let size = self.size() as u32;
                let mut v = vec![0x10, 0x00, 0x00, 0x00];
                v.extend(size.to_le_bytes());
                v.extend(0u16.to_le_bytes());
                v.extend((8 * size as u16).to_le_bytes());
                v
            }
        }
    }
}

/// Variable-length UTF-8 string datatype (base type: 1-byte unsigned integer, as the
/// reference library and h5py write it).
fn vlen_string_type() -> Vec<u8> {
    let mut v = vec![0x19, 0x01, 0x01, 0x00];
    v.extend(16u32.to_le_bytes());
    v.extend(Kind::U8.datatype());
    v
}

/// Jenkins' lookup3 `hashlittle` with seed 0: the checksum of superblocks and object
/// headers.
pub fn lookup3(data: &[u8]) -> u32 {
    let init = 0xdead_beefu32.wrapping_add(data.len() as u32);
    let (mut a, mut b, mut c) = (init, init, init);
    let word = |s: &[u8]| u32::from_le_bytes([s[0], s[1], s[2], s[3]]);
    let mut k = data;
    while k.len() > 12 {
        a = a.wrapping_add(word(&k[0..4]));
        b = b.wrapping_add(word(&k[4..8]));
        c = c.wrapping_add(word(&k[8..12]));
        // mix
        a = a.wrapping_sub(c);
        a ^= c.rotate_left(4);
        c = c.wrapping_add(b);
        b = b.wrapping_sub(a);
        b ^= a.rotate_left(6);
        a = a.wrapping_add(c);
        c = c.wrapping_sub(b);
        c ^= b.rotate_left(8);
        b = b.wrapping_add(a);
        a = a.wrapping_sub(c);
        a ^= c.rotate_left(16);
        c = c.wrapping_add(b);
        b = b.wrapping_sub(a);
        b ^= a.rotate_left(19);
        a = a.wrapping_add(c);
        c = c.wrapping_sub(b);
        c ^= b.rotate_left(4);
        b = b.wrapping_add(a);
        k = &k[12..];
    }
    if k.is_empty() {
        return c;
    }
    let mut tail = [0u8; 12];
    tail[..k.len()].copy_from_slice(k);
    a = a.wrapping_add(word(&tail[0..4]));
    b = b.wrapping_add(word(&tail[4..8]));
    c = c.wrapping_add(word(&tail[8..12]));
    // final
    c ^= b;
    c = c.wrapping_sub(b.rotate_left(14));
    a ^= c;
    a = a.wrapping_sub(c.rotate_left(11));
    b ^= a;
    b = b.wrapping_sub(a.rotate_left(25));
    c ^= b;
    c = c.wrapping_sub(b.rotate_left(16));
    a ^= c;
    a = a.wrapping_sub(c.rotate_left(4));
    b ^= a;
    b = b.wrapping_sub(a.rotate_left(14));
    c ^= b;
    c = c.wrapping_sub(b.rotate_left(24));
    c
}

/// Version-2 superblock (48 bytes): 8-byte addresses and lengths, no extension.
pub fn superblock(eof: u64, root: u64) -> Vec<u8> {
    let mut v = b"\x89HDF\r\n\x1a\n".to_vec();
    v.extend([2, 8, 8, 0]);
    v.extend(0u64.to_le_bytes());
    v.extend(UNDEF.to_le_bytes());
    v.extend(eof.to_le_bytes());
    v.extend(root.to_le_bytes());
    let sum = lookup3(&v);
    v.extend(sum.to_le_bytes());
    v
}

/// One header message: type, flags, body.
#[derive(Clone)]
pub struct Msg {
    kind: u8,
    flags: u8,
    body: Vec<u8>,
}

impl Msg {
    /// Bytes in a header, its own 4-byte prefix included.
    pub fn size(&self) -> usize {
        4 + self.body.len()
    }
}

/// Version-2 object header holding `msgs`, checksummed.
pub fn object_header(msgs: &[Msg]) -> Vec<u8> {
    let mut body = Vec::new();
    for m in msgs {
        body.push(m.kind);
        body.extend((m.body.len() as u16).to_le_bytes());
        body.push(m.flags);
        body.extend(&m.body);
    }
    let mut v = b"OHDR".to_vec();
    let n = body.len() as u64;
    if n <= u8::MAX as u64 {
        v.extend([2, 0, n as u8]);
    } else if n <= u16::MAX as u64 {
        v.extend([2, 1]);
        v.extend((n as u16).to_le_bytes());
    } else {
        v.extend([2, 2]);
        v.extend((n as u32).to_le_bytes());
    }
    v.extend(body);
    let sum = lookup3(&v);
    v.extend(sum.to_le_bytes());
    v
}

/// Padding (a NIL message) of `len` ≥ 4 bytes in all, header included.
pub fn nil(len: usize) -> Msg {
    Msg {
        kind: 0x00,
        flags: 0,
        body: vec![0; len.saturating_sub(4)],
    }
}

/// The messages of a group with compact links to `links` (name, header address).
pub fn group(links: &[(&str, u64)]) -> Vec<Msg> {
    let mut link_info = vec![0, 0];
    link_info.extend(UNDEF.to_le_bytes());
    link_info.extend(UNDEF.to_le_bytes());
    let mut m = vec![
        Msg {
            kind: 0x02,
            flags: 0,
            body: link_info,
        },
        Msg {
            kind: 0x0a,
            flags: 0,
            body: vec![0, 0],
        },
    ];
    m.extend(links.iter().map(|&(name, addr)| link(name, addr)));
    m
}

/// Hard link `name` → `addr` (names are short ASCII).
pub fn link(name: &str, addr: u64) -> Msg {
    let mut body = vec![1, 0, name.len() as u8];
    body.extend(name.as_bytes());
    body.extend(addr.to_le_bytes());
    Msg {
        kind: 0x06,
        flags: 0,
        body,
    }
}

fn dataspace(dims: Option<&[u64]>) -> Vec<u8> {
    match dims {
        None => vec![2, 0, 0, 0],
        Some(d) => {
            let mut v = vec![2, d.len() as u8, 0, 1];
            for x in d {
                v.extend(x.to_le_bytes());
            }
            v
        }
    }
}

/// The messages of a contiguous dataset of `kind` with `dims`, its storage at `addr`,
/// followed by `attrs`. An empty dataset has no storage address (readers refuse a
/// zero-sized storage at a defined one).
pub fn dataset(kind: Kind, dims: &[u64], addr: u64, attrs: &[Msg]) -> Vec<Msg> {
    let bytes = dims.iter().product::<u64>() * kind.size() as u64;
    let addr = if bytes == 0 { UNDEF } else { addr };
    let mut layout = vec![3, 1];
    layout.extend(addr.to_le_bytes());
    layout.extend(bytes.to_le_bytes());
    let mut m = vec![
        Msg {
            kind: 0x03,
            flags: 1,
            body: kind.datatype(),
        },
        Msg {
            kind: 0x01,
            flags: 0,
            body: dataspace(Some(dims)),
        },
        // Fill value: late allocation, written if set, default value (as h5py writes).
        Msg {
            kind: 0x05,
            flags: 1,
            body: vec![3, 0x0a],
        },
        Msg {
            kind: 0x08,
            flags: 0,
            body: layout,
        },
    ];
    m.extend_from_slice(attrs);
    m
}

/// A scalar attribute's value.
pub enum Value {
    U64(u64),
    F64(f64),
    /// A string stored in a global heap collection: (collection address, object index,
    /// length in bytes).
    Text(u64, u32, usize),
}

/// Scalar attribute `name` = `v`.
pub fn attribute(name: &str, v: &Value) -> Msg {
    let (dtype, data) = match *v {
        Value::U64(x) => (Kind::U64.datatype(), x.to_le_bytes().to_vec()),
        Value::F64(x) => (Kind::F64.datatype(), x.to_le_bytes().to_vec()),
        Value::Text(heap, index, len) => {
            let mut d = (len as u32).to_le_bytes().to_vec();
            d.extend(heap.to_le_bytes());
            d.extend(index.to_le_bytes());
            (vlen_string_type(), d)
        }
    };
    let space = dataspace(None);
    let mut body = vec![2, 0];
    body.extend(((name.len() + 1) as u16).to_le_bytes());
    body.extend((dtype.len() as u16).to_le_bytes());
    body.extend((space.len() as u16).to_le_bytes());
    body.extend(name.as_bytes());
    body.push(0);
    body.extend(dtype);
    body.extend(space);
    body.extend(data);
    Msg {
        kind: 0x0c,
        flags: 0,
        body,
    }
}

/// A global heap collection holding `strings` as objects 1, 2, …: its bytes (at least
/// 4 KiB, the minimum readers accept).
pub fn global_heap(strings: &[&str]) -> Vec<u8> {
    let pad8 = |n: usize| n.div_ceil(8) * 8;
    let used: usize = 16 + strings.iter().map(|s| 16 + pad8(s.len())).sum::<usize>();
    let size = (used + 16).max(4096);
    let mut v = b"GCOL".to_vec();
    v.extend([1, 0, 0, 0]);
    v.extend((size as u64).to_le_bytes());
    for (i, s) in strings.iter().enumerate() {
        v.extend(((i + 1) as u16).to_le_bytes());
        v.extend(1u16.to_le_bytes());
        v.extend(0u32.to_le_bytes());
        v.extend((s.len() as u64).to_le_bytes());
        v.extend(s.as_bytes());
        v.resize(v.len() + pad8(s.len()) - s.len(), 0);
    }
    // The free space: object 0, its size counting its own header.
    let free = size - v.len();
    v.extend(0u16.to_le_bytes());
    v.extend(0u16.to_le_bytes());
    v.extend(0u32.to_le_bytes());
    v.extend((free as u64).to_le_bytes());
    v.resize(size, 0);
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lookup3_matches_the_reference_vectors() {
        // From Bob Jenkins' lookup3.c driver: hashlittle("", 0) and
        // hashlittle("Four score and seven years ago", 30, 0).
        assert_eq!(lookup3(b""), 0xdeadbeef);
        assert_eq!(lookup3(b"Four score and seven years ago"), 0x17770551);
    }

    #[test]
    fn a_file_of_these_structures_reads_back() {
        // Superblock, root group with one dataset and a string attribute, heap, data.
        let heap_at = 48 + 512;
        let heap = global_heap(&["m/s"]);
        let data_at = heap_at + heap.len() as u64;
        let attrs = [attribute("units", &Value::Text(heap_at, 1, 3))];
        let ds = object_header(&dataset(Kind::F64, &[2, 3], data_at, &attrs));
        let ds_at = 48 + 256;
        let mut root_msgs = group(&[("x", ds_at)]);
        root_msgs.push(attribute("seed", &Value::U64(7)));
        let root = object_header(&root_msgs);
        assert!(root.len() < 256 && ds.len() < 256);
        let mut file = superblock(data_at + 48, 48);
        file.resize(48, 0);
        file.extend(&root);
        file.resize(ds_at as usize, 0);
        file.extend(&ds);
        file.resize(heap_at as usize, 0);
        file.extend(&heap);
        for x in 0..6 {
            file.extend((x as f64 * 0.5).to_le_bytes());
        }
        let f = hdf5_pure::File::from_bytes(file).unwrap();
        let d = f.dataset("x").unwrap();
        assert_eq!(d.shape().unwrap(), vec![2, 3]);
        assert_eq!(d.read_f64().unwrap(), vec![0.0, 0.5, 1.0, 1.5, 2.0, 2.5]);
        let a = d.attrs().unwrap();
        assert!(matches!(&a["units"], hdf5_pure::AttrValue::VarLenString(s) if s == "m/s"));
        let r = f.root().attrs().unwrap();
        assert!(matches!(r["seed"], hdf5_pure::AttrValue::U64(7)));
    }
}
