//! CRC-32 (ISO-HDLC, the zlib/PNG one) over byte slices: the integrity check of `.tg` blocks and the
//! frame checksum the firmware prints. One definition, shared by host and device.

const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// CRC-32 of `bytes`.
///
/// ```
/// assert_eq!(pocketsplat_core::crc::crc32(b"123456789"), 0xCBF4_3926);
/// ```
pub fn crc32(bytes: &[u8]) -> u32 {
    CRC32.checksum(bytes)
}

/// Incremental CRC-32, for data that arrives in pieces (framebuffer rows, blocks).
#[derive(Clone)]
pub struct Crc32 {
    digest: crc::Digest<'static, u32>,
}

impl Default for Crc32 {
    fn default() -> Self {
        Self::new()
    }
}

impl Crc32 {
    /// A fresh digest.
    pub fn new() -> Self {
        Self {
            digest: CRC32.digest(),
        }
    }
    /// Feeds more bytes.
    pub fn update(&mut self, bytes: &[u8]) {
        self.digest.update(bytes);
    }
    /// Feeds 16-bit words in little-endian byte order (RGB565 pixels, depth values).
    pub fn update_u16_le(&mut self, words: &[u16]) {
        for w in words {
            self.digest.update(&w.to_le_bytes());
        }
    }
    /// The checksum of everything fed so far.
    pub fn finish(self) -> u32 {
        self.digest.finalize()
    }
}
