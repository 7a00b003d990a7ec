//! Memory sized by input is asked for, not assumed: [`reserve`] and [`filled`] turn an allocation
//! the machine cannot give into an error that says how much was asked and what for, where `Vec`
//! would abort the process ("memory allocation of N bytes failed", issue 33). Every buffer whose
//! size comes from a file (a file read whole, a stream's block table and cache) goes through here;
//! the sizes are bounded by the limits first (`limits.rs`), this covers a limit raised past the
//! memory there is.

use anyhow::{anyhow, Result};

/// Reserves room for `n` more elements in `v`.
///
/// # Errors
/// When the memory cannot be had: the bytes asked for.
pub fn reserve<T>(v: &mut Vec<T>, n: usize) -> Result<()> {
    v.try_reserve_exact(n).map_err(|_| {
        anyhow!(
            "{} bytes of memory are not to be had",
            (n as u128) * std::mem::size_of::<T>() as u128
        )
    })
}

/// `n` copies of `value`, or an error when the memory cannot be had.
///
/// # Errors
/// As [`reserve`].
pub fn filled<T: Clone>(value: T, n: usize) -> Result<Vec<T>> {
    let mut v = Vec::new();
    reserve(&mut v, n)?;
    v.resize(n, value);
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memory_that_cannot_be_had_is_an_error() {
        let err = filled(0u64, usize::MAX / 4).unwrap_err().to_string();
        assert!(err.contains("bytes of memory are not to be had"), "{err}");
        assert_eq!(filled(7u8, 3).unwrap(), vec![7, 7, 7]);
    }
}
