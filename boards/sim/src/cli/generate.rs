//! `pocketsplat generate -o big.ply --triangles 100M`: a large test scan (a displaced sphere,
//! binary PLY) for measuring bakes without downloading one.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Result;
use indicatif::{ProgressBar, ProgressStyle};
use pocketsplat_sim::args;
use pocketsplat_sim::generate::Sphere;

/// The arguments of `generate`.
#[derive(Debug, clap::Args)]
pub struct GenerateArgs {
    /// Output PLY file.
    #[arg(short, long)]
    out: PathBuf,
    /// Triangles, about (K, M, G = 1024, 1024², 1024³; 1e6 style too): the sphere has 12 n² for
    /// the nearest n.
    #[arg(long, default_value = "1M", value_parser = triangles)]
    triangles: u64,
    /// Seed of the bumps and the jitter.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

impl GenerateArgs {
    /// The file the command writes (what its errors name).
    pub fn output(&self) -> &std::path::Path {
        &self.out
    }
}

/// Triangles: `100M`, or `1e8`.
fn triangles(text: &str) -> Result<u64, String> {
    if let Some(n) = text
        .parse::<f64>()
        .ok()
        .filter(|n| n.is_finite() && (48.0..=1e11).contains(n))
    {
        return Ok(n as u64);
    }
    args::size::<u64>(48, 100_000_000_000)(text)
}

/// The `generate` command.
///
/// # Errors
/// When the file cannot be written; nothing is left then.
pub fn run(args: &GenerateArgs) -> Result<()> {
    let t = Instant::now();
    let s = Sphere::with_triangles(args.triangles, args.seed);
    let bar = ProgressBar::new(s.file_bytes());
    bar.set_style(
        ProgressStyle::with_template(
            "writing {bar:40} {bytes}/{total_bytes} ({elapsed}, {eta} left)",
        )
        .expect("static template")
        .progress_chars("=> "),
    );
    s.write(&args.out, &|n| bar.inc(n))?;
    bar.finish_and_clear();
    eprintln!(
        "{}: displaced sphere, {} triangles, {} vertices, {} bytes, in {:.1} s",
        args.out.display(),
        s.triangles(),
        s.vertices(),
        s.file_bytes(),
        t.elapsed().as_secs_f64()
    );
    Ok(())
}
