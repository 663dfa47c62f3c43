//! CDR (OMG Common Data Representation, XCDR1) as ROS 2 serializes messages: a 4-byte
//! encapsulation header (`00 01 00 00`: plain CDR, little endian), then every primitive
//! aligned to its own size (at most 8) counted from the end of that header, strings as a
//! `uint32` length that includes the terminating NUL, then the bytes and the NUL, sequences
//! as a `uint32` element count then the elements, fixed arrays as the bare elements.
//!
//! The writer always produces little endian; the reader accepts both byte orders (header
//! `00 00` big, `00 01` little), as other tools may write either.

/// The encapsulation header of little-endian plain CDR.
pub const LITTLE_ENDIAN_HEADER: [u8; 4] = [0, 1, 0, 0];

/// A CDR writer into a reusable buffer (cleared by [`CdrWriter::start`]).
pub struct CdrWriter<'a> {
    buf: &'a mut Vec<u8>,
}

impl<'a> CdrWriter<'a> {
    /// Clears `buf` and writes the encapsulation header.
    pub fn start(buf: &'a mut Vec<u8>) -> Self {
        buf.clear();
        buf.extend_from_slice(&LITTLE_ENDIAN_HEADER);
        CdrWriter { buf }
    }

    /// Pads with zeros to a multiple of `n` counted after the header.
    fn align(&mut self, n: usize) {
        let pos = self.buf.len() - 4;
        let pad = pos.next_multiple_of(n) - pos;
        self.buf.resize(self.buf.len() + pad, 0);
    }

    pub fn u8(&mut self, v: u8) {
        self.buf.push(v);
    }
    pub fn i8(&mut self, v: i8) {
        self.buf.push(v as u8);
    }
    pub fn bool(&mut self, v: bool) {
        self.buf.push(u8::from(v));
    }
    pub fn u32(&mut self, v: u32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub fn i32(&mut self, v: i32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub fn f32(&mut self, v: f32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub fn i64(&mut self, v: i64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub fn f64(&mut self, v: f64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    pub fn string(&mut self, s: &str) {
        self.u32(s.len() as u32 + 1);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
    }

    /// A sequence's element count (the elements follow, each aligned as its type).
    pub fn len(&mut self, n: usize) {
        self.u32(n as u32);
    }

    /// `uint8[]` (or `int8[]` given as bytes): count, then the bytes.
    pub fn bytes(&mut self, b: &[u8]) {
        self.len(b.len());
        self.buf.extend_from_slice(b);
    }

    pub fn f32_seq(&mut self, v: impl ExactSizeIterator<Item = f32>) {
        self.len(v.len());
        for x in v {
            self.buf.extend_from_slice(&x.to_le_bytes());
        }
    }

    pub fn f64_seq(&mut self, v: &[f64]) {
        self.len(v.len());
        self.f64_array(v);
    }

    /// A fixed-size `float64[N]`: the elements only.
    pub fn f64_array(&mut self, v: &[f64]) {
        if !v.is_empty() {
            self.align(8);
        }
        for x in v {
            self.buf.extend_from_slice(&x.to_le_bytes());
        }
    }
}

/// A CDR reader; errors say what ended early or is malformed.
pub struct CdrReader<'a> {
    data: &'a [u8],
    pos: usize,
    little: bool,
}

impl<'a> CdrReader<'a> {
    pub fn new(bytes: &'a [u8]) -> Result<Self, String> {
        if bytes.len() < 4 {
            return Err("shorter than the CDR encapsulation header".into());
        }
        // Byte 0 is 0 for plain CDR (1 would be parameter-list CDR, 2.. XCDR2).
        let little = match (bytes[0], bytes[1]) {
            (0, 0) => false,
            (0, 1) => true,
            (a, b) => return Err(format!("unsupported CDR encapsulation {a:02x} {b:02x}")),
        };
        Ok(CdrReader {
            data: &bytes[4..],
            pos: 0,
            little,
        })
    }

    fn take<const N: usize>(&mut self, what: &str) -> Result<[u8; N], String> {
        self.pos = self.pos.next_multiple_of(N);
        let b = self
            .data
            .get(self.pos..self.pos + N)
            .ok_or_else(|| format!("message ends early (in {what})"))?;
        self.pos += N;
        let mut a = [0u8; N];
        a.copy_from_slice(b);
        if !self.little {
            a.reverse();
        }
        Ok(a)
    }

    pub fn u8(&mut self) -> Result<u8, String> {
        self.take::<1>("a byte").map(|b| b[0])
    }
    pub fn u32(&mut self) -> Result<u32, String> {
        self.take::<4>("a uint32").map(u32::from_le_bytes)
    }
    pub fn i32(&mut self) -> Result<i32, String> {
        self.take::<4>("an int32").map(i32::from_le_bytes)
    }
    pub fn f32(&mut self) -> Result<f32, String> {
        self.take::<4>("a float32").map(f32::from_le_bytes)
    }
    pub fn i64(&mut self) -> Result<i64, String> {
        self.take::<8>("an int64").map(i64::from_le_bytes)
    }
    pub fn f64(&mut self) -> Result<f64, String> {
        self.take::<8>("a float64").map(f64::from_le_bytes)
    }

    /// A sequence length, checked against the bytes left (each element takes at least
    /// `min_size` bytes), so a corrupt count cannot ask for a huge allocation.
    pub fn len(&mut self, min_size: usize) -> Result<usize, String> {
        let n = self.u32()? as usize;
        let left = self.data.len() - self.pos.min(self.data.len());
        if n.saturating_mul(min_size.max(1)) > left {
            return Err(format!(
                "a sequence of {n} elements does not fit in the {left} bytes left"
            ));
        }
        Ok(n)
    }

    pub fn string(&mut self) -> Result<String, String> {
        let n = self.len(1)?;
        let b = &self.data[self.pos..self.pos + n];
        self.pos += n;
        // The length counts the terminating NUL; tolerate writers that leave it out.
        let b = b.strip_suffix(&[0]).unwrap_or(b);
        String::from_utf8(b.to_vec()).map_err(|_| "a string is not UTF-8".to_string())
    }

    pub fn bytes(&mut self) -> Result<&'a [u8], String> {
        let n = self.len(1)?;
        let b = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(b)
    }

    pub fn f32_seq(&mut self) -> Result<Vec<f32>, String> {
        let n = self.len(4)?;
        (0..n).map(|_| self.f32()).collect()
    }

    pub fn f64_seq(&mut self) -> Result<Vec<f64>, String> {
        let n = self.len(8)?;
        (0..n).map(|_| self.f64()).collect()
    }

    pub fn f64_array<const N: usize>(&mut self) -> Result<[f64; N], String> {
        let mut a = [0.0; N];
        for x in &mut a {
            *x = self.f64()?;
        }
        Ok(a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-computed `std_msgs/Header` + `float64`: the stamp's two 4-byte fields at 0 and
    /// 4, the string length at 8, "map\0" at 12..16, then the double aligned to 16 (no
    /// padding needed); with "base" the string ends at 17 and 7 bytes of padding follow.
    #[test]
    fn header_and_double_are_laid_out_as_ros2_does() {
        let mut buf = Vec::new();
        let mut w = CdrWriter::start(&mut buf);
        w.i32(7);
        w.u32(250_000_000);
        w.string("map");
        w.f64(1.5);
        let mut want = vec![0, 1, 0, 0, 7, 0, 0, 0];
        want.extend(250_000_000u32.to_le_bytes());
        want.extend([4, 0, 0, 0, b'm', b'a', b'p', 0]);
        want.extend(1.5f64.to_le_bytes());
        assert_eq!(buf, want);

        let mut w = CdrWriter::start(&mut buf);
        w.i32(1);
        w.u32(2);
        w.string("base");
        w.f64(-2.0);
        w.u8(9);
        w.f32(0.5);
        w.bytes(&[1, 2, 3]);
        w.f32_seq([4.0f32].into_iter());
        w.i64(-3);
        let mut want = vec![0, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 5, 0, 0, 0];
        want.extend(b"base\0");
        want.extend([0; 7]); // 17 -> 24
        want.extend((-2.0f64).to_le_bytes()); // 24..32
        want.push(9); // 32
        want.extend([0; 3]); // 33 -> 36
        want.extend(0.5f32.to_le_bytes()); // 36..40
        want.extend([3, 0, 0, 0, 1, 2, 3]); // 40..47
        want.push(0); // 47 -> 48
        want.extend([1, 0, 0, 0]); // 48..52
        want.extend(4.0f32.to_le_bytes()); // 52..56
        want.extend((-3i64).to_le_bytes()); // 56..64, already aligned
        assert_eq!(buf, want);

        let mut r = CdrReader::new(&buf).unwrap();
        assert_eq!((r.i32().unwrap(), r.u32().unwrap()), (1, 2));
        assert_eq!(r.string().unwrap(), "base");
        assert_eq!(r.f64().unwrap(), -2.0);
        assert_eq!(r.u8().unwrap(), 9);
        assert_eq!(r.f32().unwrap(), 0.5);
        assert_eq!(r.bytes().unwrap(), &[1, 2, 3]);
        assert_eq!(r.f32_seq().unwrap(), vec![4.0]);
        assert_eq!(r.i64().unwrap(), -3);
        assert!(r.u8().unwrap_err().contains("ends early"));
    }

    #[test]
    fn big_endian_is_read_and_bad_input_is_an_error() {
        let mut be = vec![0, 0, 0, 0];
        be.extend(5u32.to_be_bytes());
        be.extend([0; 4]);
        be.extend(2.5f64.to_be_bytes());
        let mut r = CdrReader::new(&be).unwrap();
        assert_eq!(r.u32().unwrap(), 5);
        assert_eq!(r.f64().unwrap(), 2.5);
        assert!(CdrReader::new(&[0, 1]).is_err());
        assert!(CdrReader::new(&[0, 3, 0, 0]).is_err());
        // A sequence claiming more elements than bytes left.
        let mut r = CdrReader::new(&[0, 1, 0, 0, 255, 255, 255, 255, 1]).unwrap();
        assert!(r.f64_seq().unwrap_err().contains("does not fit"));
    }
}
