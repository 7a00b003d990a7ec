//! A file on a FAT-formatted SD card, read through embedded-sdmmc (`sdmmc` feature): the same code
//! path whether the [`BlockDevice`] is an SD card on SPI, a disk image on the host or semihosting
//! file reads under QEMU.

use embedded_sdmmc::{BlockDevice, RawFile, TimeSource, Timestamp, VolumeManager};

use super::ChunkSource;

/// An open file on a FAT volume, as a [`ChunkSource`]. The caller opens the volume, directory and
/// file (and closes them when done); reads seek and then read until the buffer is full.
pub struct SdFile<
    'v,
    D: BlockDevice,
    T: TimeSource,
    const MAX_DIRS: usize,
    const MAX_FILES: usize,
    const MAX_VOLUMES: usize,
> {
    volumes: &'v VolumeManager<D, T, MAX_DIRS, MAX_FILES, MAX_VOLUMES>,
    file: RawFile,
}

impl<
        'v,
        D: BlockDevice,
        T: TimeSource,
        const MAX_DIRS: usize,
        const MAX_FILES: usize,
        const MAX_VOLUMES: usize,
    > SdFile<'v, D, T, MAX_DIRS, MAX_FILES, MAX_VOLUMES>
{
    /// The open file `file` of `volumes`.
    pub fn new(
        volumes: &'v VolumeManager<D, T, MAX_DIRS, MAX_FILES, MAX_VOLUMES>,
        file: RawFile,
    ) -> Self {
        Self { volumes, file }
    }

    /// The file's length in bytes.
    ///
    /// # Errors
    /// When the handle is no longer valid.
    pub fn len(&self) -> Result<u32, embedded_sdmmc::Error<D::Error>> {
        self.volumes.file_length(self.file)
    }

    /// Whether the file is empty.
    ///
    /// # Errors
    /// When the handle is no longer valid.
    pub fn is_empty(&self) -> Result<bool, embedded_sdmmc::Error<D::Error>> {
        self.len().map(|n| n == 0)
    }
}

impl<
        D: BlockDevice,
        T: TimeSource,
        const MAX_DIRS: usize,
        const MAX_FILES: usize,
        const MAX_VOLUMES: usize,
    > ChunkSource for SdFile<'_, D, T, MAX_DIRS, MAX_FILES, MAX_VOLUMES>
where
    D::Error: core::fmt::Debug,
{
    type Error = embedded_sdmmc::Error<D::Error>;

    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> Result<(), Self::Error> {
        let offset = u32::try_from(offset).map_err(|_| embedded_sdmmc::Error::EndOfFile)?;
        self.volumes.file_seek_from_start(self.file, offset)?;
        let mut done = 0;
        while done < buf.len() {
            let n = self.volumes.read(self.file, &mut buf[done..])?;
            if n == 0 {
                return Err(embedded_sdmmc::Error::EndOfFile);
            }
            done += n;
        }
        Ok(())
    }

    fn byte_len(&self) -> Option<u64> {
        self.len().ok().map(u64::from)
    }
}

/// A clock for a read-only volume manager: every timestamp is the FAT epoch (nothing is written, so
/// no date is ever stored). One definition for the simulator, the QEMU firmware and a board.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoClock;

impl TimeSource for NoClock {
    fn get_timestamp(&self) -> Timestamp {
        Timestamp {
            year_since_1970: 10,
            zero_indexed_month: 0,
            zero_indexed_day: 0,
            hours: 0,
            minutes: 0,
            seconds: 0,
        }
    }
}
