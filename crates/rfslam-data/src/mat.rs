//! A small reader for MATLAB level-5 MAT files (the format of `save` up to `-v7`).
//!
//! Supported: the 128-byte header (little-endian files, endian indicator `IM`), data
//! elements with normal and small (4-byte) tags, `miCOMPRESSED` elements (zlib) wrapping
//! `miMATRIX`, and numeric arrays of every class (double, single, int8..uint64, logical),
//! whose real part is converted to `f64` whatever the storage type. Imaginary parts are
//! ignored. Cell, struct, object, char and sparse variables are listed in
//! [`MatFile::skipped`] and otherwise skipped. MAT v7.3 (HDF5) files are rejected with
//! [`MatError::NotMat`].
//!
//! Reference: MathWorks, "MAT-File Format", level 5 MAT-file chapter.

use std::io::Read;
use std::path::Path;

use crate::error::DataError;

/// Why a byte buffer could not be read as a MAT v5 file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MatError {
    /// The buffer does not start with a level-5 MAT header.
    #[error("not a MATLAB level-5 MAT file ({0})")]
    NotMat(String),
    /// A big-endian file (endian indicator `MI`).
    #[error("big-endian MAT files are not supported (endian indicator `MI`)")]
    BigEndian,
    /// The data ends inside an element.
    #[error("truncated at byte {offset}: {what} needs {needed} bytes, {available} left")]
    Truncated {
        /// Byte offset (in the file, or in the decompressed element) where reading stopped.
        offset: usize,
        /// What was being read.
        what: &'static str,
        /// Bytes needed.
        needed: usize,
        /// Bytes available.
        available: usize,
    },
    /// A compressed element that zlib could not inflate.
    #[error("compressed element at byte {offset}: {message}")]
    Inflate {
        /// Byte offset of the element's tag.
        offset: usize,
        /// zlib's message.
        message: String,
    },
    /// A structurally invalid element.
    #[error("byte {offset}: {message}")]
    Malformed {
        /// Byte offset of the offending element.
        offset: usize,
        /// What is wrong.
        message: String,
    },
}

/// A numeric variable: its name, dimensions and real part in column-major order.
#[derive(Debug, Clone, PartialEq)]
pub struct MatArray {
    /// Variable name.
    pub name: String,
    /// Dimensions (at least two).
    pub dims: Vec<usize>,
    /// Real part, column-major (MATLAB order), converted to `f64`.
    pub data: Vec<f64>,
}

impl MatArray {
    /// Number of rows (first dimension).
    pub fn rows(&self) -> usize {
        self.dims.first().copied().unwrap_or(0)
    }

    /// Number of columns (product of the remaining dimensions).
    pub fn cols(&self) -> usize {
        self.dims.iter().skip(1).product()
    }

    /// Element `(r, c)` of a 2-D array, `None` out of range.
    pub fn get(&self, r: usize, c: usize) -> Option<f64> {
        if r < self.rows() && c < self.cols() { self.data.get(c * self.rows() + r).copied() } else { None }
    }
}

/// The variables of a MAT file.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MatFile {
    /// Numeric variables, in file order.
    pub arrays: Vec<MatArray>,
    /// Variables that were skipped: name and MATLAB class (`cell`, `struct`, `char`...).
    pub skipped: Vec<(String, &'static str)>,
}

impl MatFile {
    /// Parses a whole MAT file held in memory.
    pub fn parse(bytes: &[u8]) -> Result<MatFile, MatError> {
        parse(bytes)
    }

    /// Reads and parses the MAT file at `path`; errors name the file.
    pub fn read(path: &Path) -> Result<MatFile, DataError> {
        let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
        parse(&bytes).map_err(|source| DataError::Mat { path: path.to_path_buf(), source })
    }

    /// The numeric variable called `name`.
    pub fn get(&self, name: &str) -> Option<&MatArray> {
        self.arrays.iter().find(|a| a.name == name)
    }

    /// Names of all variables (numeric and skipped), in file order within each group.
    pub fn names(&self) -> Vec<&str> {
        self.arrays.iter().map(|a| a.name.as_str()).chain(self.skipped.iter().map(|(n, _)| n.as_str())).collect()
    }
}

// Data types (miXXX).
const MI_INT8: u32 = 1;
const MI_UINT8: u32 = 2;
const MI_INT16: u32 = 3;
const MI_UINT16: u32 = 4;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_SINGLE: u32 = 7;
const MI_DOUBLE: u32 = 9;
const MI_INT64: u32 = 12;
const MI_UINT64: u32 = 13;
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;
const MI_UTF8: u32 = 16;

/// MATLAB class names by class code (mxXXX_CLASS).
fn class_name(class: u8) -> &'static str {
    match class {
        1 => "cell",
        2 => "struct",
        3 => "object",
        4 => "char",
        5 => "sparse",
        6 => "double",
        7 => "single",
        8 => "int8",
        9 => "uint8",
        10 => "int16",
        11 => "uint16",
        12 => "int32",
        13 => "uint32",
        14 => "int64",
        15 => "uint64",
        16 => "function",
        17 => "opaque",
        _ => "unknown",
    }
}

/// Reads little-endian values from a byte slice with offsets relative to `base`.
struct Cursor<'a> {
    buf: &'a [u8],
    pos: usize,
    /// Offset of `buf[0]` in the file (for messages); 0 inside decompressed data.
    base: usize,
}

/// One data element: type, payload and the offset of its tag.
struct Element<'a> {
    ty: u32,
    data: &'a [u8],
    offset: usize,
}

impl<'a> Cursor<'a> {
    fn remaining(&self) -> usize {
        self.buf.len() - self.pos
    }

    fn take(&mut self, n: usize, what: &'static str) -> Result<&'a [u8], MatError> {
        if self.remaining() < n {
            return Err(MatError::Truncated {
                offset: self.base + self.pos,
                what,
                needed: n,
                available: self.remaining(),
            });
        }
        let s = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn u32(&mut self, what: &'static str) -> Result<u32, MatError> {
        let b = self.take(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// Reads one element (tag, payload, padding to 8 bytes; compressed payloads unpadded).
    fn element(&mut self, what: &'static str) -> Result<Element<'a>, MatError> {
        let offset = self.base + self.pos;
        let first = self.u32(what)?;
        if first >> 16 != 0 {
            // Small data element: type in the low half, size in the high half, 4 bytes data.
            let ty = first & 0xffff;
            let n = (first >> 16) as usize;
            if n > 4 {
                return Err(MatError::Malformed { offset, message: format!("small element of {n} bytes (at most 4)") });
            }
            let data = self.take(4, what)?;
            return Ok(Element { ty, data: &data[..n], offset });
        }
        let n = self.u32(what)? as usize;
        let data = self.take(n, what)?;
        if first != MI_COMPRESSED {
            let pad = (8 - n % 8) % 8;
            // The last element of a file may omit its padding.
            let pad = pad.min(self.remaining());
            self.pos += pad;
        }
        Ok(Element { ty: first, data, offset })
    }
}

fn parse(bytes: &[u8]) -> Result<MatFile, MatError> {
    if bytes.len() < 128 {
        if bytes.starts_with(b"MATLAB") {
            return Err(MatError::Truncated { offset: 0, what: "header", needed: 128, available: bytes.len() });
        }
        return Err(MatError::NotMat(format!("{} bytes, shorter than the 128-byte header", bytes.len())));
    }
    if !bytes.starts_with(b"MATLAB 5.0 MAT-file") {
        if bytes.starts_with(b"MATLAB 7.3 MAT-file") {
            return Err(MatError::NotMat("MAT v7.3 is HDF5; save with -v7 instead".into()));
        }
        return Err(MatError::NotMat("the header does not start with `MATLAB 5.0 MAT-file`".into()));
    }
    match &bytes[126..128] {
        b"IM" => {}
        b"MI" => return Err(MatError::BigEndian),
        other => {
            return Err(MatError::NotMat(format!("endian indicator {:?} is neither `IM` nor `MI`", other)));
        }
    }
    let mut out = MatFile::default();
    let mut cur = Cursor { buf: &bytes[128..], pos: 0, base: 128 };
    while cur.remaining() > 0 {
        let el = cur.element("data element")?;
        top_level(el, &mut out)?;
    }
    Ok(out)
}

fn top_level(el: Element<'_>, out: &mut MatFile) -> Result<(), MatError> {
    match el.ty {
        MI_MATRIX => matrix(el.data, el.offset + 8, out),
        MI_COMPRESSED => {
            let mut inflated = Vec::new();
            flate2::read::ZlibDecoder::new(el.data)
                .read_to_end(&mut inflated)
                .map_err(|e| MatError::Inflate { offset: el.offset, message: e.to_string() })?;
            let mut cur = Cursor { buf: &inflated, pos: 0, base: 0 };
            while cur.remaining() > 0 {
                let inner = cur.element("compressed data element").map_err(|e| in_compressed(e, el.offset))?;
                if inner.ty == MI_COMPRESSED {
                    return Err(MatError::Malformed { offset: el.offset, message: "nested compressed element".into() });
                }
                top_level(inner, out).map_err(|e| in_compressed(e, el.offset))?;
            }
            Ok(())
        }
        // Anything else at top level (e.g. a stray padding element) is ignored.
        _ => Ok(()),
    }
}

/// Re-labels an error found inside decompressed data with the compressed element's offset.
fn in_compressed(e: MatError, offset: usize) -> MatError {
    match e {
        MatError::Truncated { offset: inner, what, needed, available } => MatError::Malformed {
            offset,
            message: format!(
                "inside the compressed element, at decompressed byte {inner}: {what} needs {needed} bytes, {available} left"
            ),
        },
        MatError::Malformed { offset: inner, message } if inner < offset => MatError::Malformed {
            offset,
            message: format!("inside the compressed element, at decompressed byte {inner}: {message}"),
        },
        other => other,
    }
}

/// Parses the payload of an `miMATRIX` element starting at file offset `offset`.
fn matrix(data: &[u8], offset: usize, out: &mut MatFile) -> Result<(), MatError> {
    if data.is_empty() {
        return Ok(()); // an empty miMATRIX (allowed in cells) carries nothing
    }
    let mut cur = Cursor { buf: data, pos: 0, base: offset };
    let flags = cur.element("array flags")?;
    if flags.ty != MI_UINT32 || flags.data.len() < 8 {
        return Err(MatError::Malformed {
            offset: flags.offset,
            message: "array flags must be 8 bytes of miUINT32".into(),
        });
    }
    let class = flags.data[0];
    let dims_el = cur.element("dimensions")?;
    if dims_el.ty != MI_INT32 || dims_el.data.len() % 4 != 0 {
        return Err(MatError::Malformed { offset: dims_el.offset, message: "dimensions must be miINT32".into() });
    }
    let mut dims = Vec::with_capacity(dims_el.data.len() / 4);
    for c in dims_el.data.chunks_exact(4) {
        let d = i32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        if d < 0 {
            return Err(MatError::Malformed { offset: dims_el.offset, message: format!("negative dimension {d}") });
        }
        dims.push(d as usize);
    }
    let name_el = cur.element("array name")?;
    if name_el.ty != MI_INT8 && name_el.ty != MI_UINT8 && name_el.ty != MI_UTF8 {
        return Err(MatError::Malformed { offset: name_el.offset, message: "array name must be miINT8".into() });
    }
    let name = String::from_utf8_lossy(name_el.data).into_owned();
    if !(6..=15).contains(&class) {
        out.skipped.push((name, class_name(class)));
        return Ok(());
    }
    let n = dims.iter().try_fold(1usize, |a, &d| a.checked_mul(d)).ok_or_else(|| MatError::Malformed {
        offset: dims_el.offset,
        message: format!("dimensions {dims:?} overflow"),
    })?;
    let real = cur.element("real part")?;
    let data = numeric(&real, n)?;
    out.arrays.push(MatArray { name, dims, data });
    Ok(())
}

/// Converts a numeric element holding `n` values to `f64`.
fn numeric(el: &Element<'_>, n: usize) -> Result<Vec<f64>, MatError> {
    let width = match el.ty {
        MI_INT8 | MI_UINT8 => 1,
        MI_INT16 | MI_UINT16 => 2,
        MI_INT32 | MI_UINT32 | MI_SINGLE => 4,
        MI_DOUBLE | MI_INT64 | MI_UINT64 => 8,
        t => return Err(MatError::Malformed { offset: el.offset, message: format!("data type {t} is not numeric") }),
    };
    if el.data.len() != n * width {
        return Err(MatError::Malformed {
            offset: el.offset,
            message: format!("real part has {} bytes, {} values of {} bytes expected", el.data.len(), n, width),
        });
    }
    let d = el.data;
    let v: Vec<f64> = match el.ty {
        MI_INT8 => d.iter().map(|&b| b as i8 as f64).collect(),
        MI_UINT8 => d.iter().map(|&b| b as f64).collect(),
        MI_INT16 => d.chunks_exact(2).map(|c| i16::from_le_bytes([c[0], c[1]]) as f64).collect(),
        MI_UINT16 => d.chunks_exact(2).map(|c| u16::from_le_bytes([c[0], c[1]]) as f64).collect(),
        MI_INT32 => d.chunks_exact(4).map(|c| i32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64).collect(),
        MI_UINT32 => d.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64).collect(),
        MI_SINGLE => d.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64).collect(),
        MI_DOUBLE => d.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8]))).collect(),
        MI_INT64 => d.chunks_exact(8).map(|c| i64::from_le_bytes(c.try_into().unwrap_or([0; 8])) as f64).collect(),
        _ => d.chunks_exact(8).map(|c| u64::from_le_bytes(c.try_into().unwrap_or([0; 8])) as f64).collect(),
    };
    Ok(v)
}

/// Builders of MAT v5 byte streams, for tests (here and in the crates that read worlds).
/// Always compiled, as [`crate::testutil`] is.
pub mod build {
    /// Appends a data element (tag, payload, padding to 8 bytes).
    pub fn element(out: &mut Vec<u8>, ty: u32, payload: &[u8]) {
        out.extend_from_slice(&ty.to_le_bytes());
        out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
        out.extend_from_slice(payload);
        out.resize(out.len() + (8 - payload.len() % 8) % 8, 0);
    }

    /// Appends a small data element (at most 4 bytes of payload).
    pub fn small_element(out: &mut Vec<u8>, ty: u32, payload: &[u8]) {
        debug_assert!(payload.len() <= 4);
        out.extend_from_slice(&(ty | ((payload.len() as u32) << 16)).to_le_bytes());
        let mut p = [0u8; 4];
        p[..payload.len()].copy_from_slice(payload);
        out.extend_from_slice(&p);
    }

    /// The 128-byte header of a little-endian level-5 file.
    pub fn header() -> Vec<u8> {
        let mut h = b"MATLAB 5.0 MAT-file, built by rfslam-data tests".to_vec();
        h.resize(116, b' ');
        h.extend_from_slice(&[0; 8]);
        h.extend_from_slice(&0x0100u16.to_le_bytes());
        h.extend_from_slice(b"IM");
        h
    }

    /// An `miMATRIX` element of class double (`class` 6) holding `data` (column-major).
    /// A name of at most 4 bytes uses the small-element format.
    pub fn double_matrix(name: &str, rows: usize, cols: usize, data: &[f64]) -> Vec<u8> {
        let mut payload = Vec::new();
        array_header(&mut payload, 6, rows, cols, name);
        let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        element(&mut payload, super::MI_DOUBLE, &bytes);
        let mut out = Vec::new();
        element(&mut out, super::MI_MATRIX, &payload);
        out
    }

    /// Array flags, dimensions and name of an `miMATRIX` payload.
    pub fn array_header(payload: &mut Vec<u8>, class: u8, rows: usize, cols: usize, name: &str) {
        element(payload, super::MI_UINT32, &[class, 0, 0, 0, 0, 0, 0, 0]);
        let dims: Vec<u8> = [rows as i32, cols as i32].iter().flat_map(|d| d.to_le_bytes()).collect();
        element(payload, super::MI_INT32, &dims);
        if name.len() <= 4 {
            small_element(payload, super::MI_INT8, name.as_bytes());
        } else {
            element(payload, super::MI_INT8, name.as_bytes());
        }
    }

    /// Wraps elements in one `miCOMPRESSED` element (zlib).
    pub fn compressed(elements: &[u8]) -> Vec<u8> {
        use std::io::Write;
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        // Writing to a Vec cannot fail.
        let _ = z.write_all(elements);
        let data = z.finish().unwrap_or_default();
        let mut out = Vec::new();
        out.extend_from_slice(&super::MI_COMPRESSED.to_le_bytes());
        out.extend_from_slice(&(data.len() as u32).to_le_bytes());
        out.extend_from_slice(&data);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::build::*;
    use super::*;

    fn file(elements: &[Vec<u8>]) -> Vec<u8> {
        let mut f = header();
        for e in elements {
            f.extend_from_slice(e);
        }
        f
    }

    #[test]
    fn reads_plain_and_compressed_doubles() {
        let a = double_matrix("A", 2, 3, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let b = compressed(&double_matrix("Longer_name", 1, 2, &[-0.5, 1e300]));
        let m = MatFile::parse(&file(&[a, b])).unwrap();
        let a = m.get("A").unwrap();
        assert_eq!(a.dims, vec![2, 3]);
        assert_eq!(a.get(1, 2), Some(6.0));
        assert_eq!(a.get(0, 1), Some(3.0));
        assert_eq!(a.get(2, 0), None);
        assert_eq!(m.get("Longer_name").unwrap().data, vec![-0.5, 1e300]);
    }

    #[test]
    fn converts_integer_storage_and_skips_other_classes() {
        // A double array stored as int16 (as MATLAB does for integer-valued data).
        let mut p = Vec::new();
        array_header(&mut p, 6, 1, 3, "ints");
        let vals: Vec<u8> = [-3i16, 0, 700].iter().flat_map(|v| v.to_le_bytes()).collect();
        element(&mut p, MI_INT16, &vals);
        let mut ints = Vec::new();
        element(&mut ints, MI_MATRIX, &p);
        // A uint8 class array with small-element data.
        let mut p = Vec::new();
        array_header(&mut p, 9, 1, 2, "u8");
        small_element(&mut p, MI_UINT8, &[7, 255]);
        let mut u8s = Vec::new();
        element(&mut u8s, MI_MATRIX, &p);
        // A char array: skipped.
        let mut p = Vec::new();
        array_header(&mut p, 4, 1, 2, "txt");
        small_element(&mut p, 17, &[b'h', 0, b'i', 0]);
        let mut txt = Vec::new();
        element(&mut txt, MI_MATRIX, &p);
        let m = MatFile::parse(&file(&[ints, compressed(&u8s), txt])).unwrap();
        assert_eq!(m.get("ints").unwrap().data, vec![-3.0, 0.0, 700.0]);
        assert_eq!(m.get("u8").unwrap().data, vec![7.0, 255.0]);
        assert_eq!(m.skipped, vec![("txt".to_string(), "char")]);
        assert_eq!(m.names(), vec!["ints", "u8", "txt"]);
    }

    #[test]
    fn rejects_non_mat_big_endian_and_truncated() {
        assert!(matches!(MatFile::parse(b"hello"), Err(MatError::NotMat(_))));
        let mut not_mat = vec![b'x'; 200];
        not_mat[..5].copy_from_slice(b"PK\x03\x04z");
        assert!(matches!(MatFile::parse(&not_mat), Err(MatError::NotMat(_))));
        let mut be = header();
        be[126..128].copy_from_slice(b"MI");
        assert_eq!(MatFile::parse(&be), Err(MatError::BigEndian));

        let full = file(&[double_matrix("A", 2, 2, &[1.0, 2.0, 3.0, 4.0])]);
        for cut in [100, 131, 140, full.len() - 9] {
            let e = MatFile::parse(&full[..cut]).unwrap_err();
            assert!(matches!(e, MatError::Truncated { .. }), "cut at {cut}: {e:?}");
        }
        let z = file(&[compressed(&double_matrix("A", 2, 2, &[1.0, 2.0, 3.0, 4.0]))]);
        let e = MatFile::parse(&z[..z.len() - 6]).unwrap_err();
        assert!(matches!(e, MatError::Truncated { .. }), "{e:?}");
        // A compressed element whose length is right but whose stream is damaged.
        let mut bad = z.clone();
        let n = bad.len();
        bad[n - 10..].iter_mut().for_each(|b| *b ^= 0x5a);
        let e = MatFile::parse(&bad).unwrap_err();
        assert!(matches!(e, MatError::Inflate { .. } | MatError::Malformed { .. }), "{e:?}");
    }

    #[test]
    fn wrong_data_size_is_malformed() {
        let mut p = Vec::new();
        array_header(&mut p, 6, 2, 2, "A");
        element(&mut p, MI_DOUBLE, &1.0f64.to_le_bytes());
        let mut a = Vec::new();
        element(&mut a, MI_MATRIX, &p);
        let e = MatFile::parse(&file(&[a])).unwrap_err();
        assert!(e.to_string().contains("4 values"), "{e}");
    }
}
