//! `pocketsplat migrate IN.tg -o OUT.tg [--layout …]`: a `.tg` file in another layout.

use std::path::PathBuf;

use anyhow::Result;
use pocketsplat_core::tg::write::Layout;

/// The arguments of `migrate`.
#[derive(Debug, clap::Args)]
pub struct MigrateArgs {
    /// The `.tg` file (version 1, 2 or 3).
    input: PathBuf,
    /// Output file.
    #[arg(short, long)]
    out: PathBuf,
    /// bricked (version 3, for streaming; the default), bricked:LEVEL (bricks below that level),
    /// unbricked (version 3, every level one array: what a resident walk draws fastest) or v2.
    #[arg(long, default_value = "bricked", value_parser = pocketsplat_sim::migrate::layout)]
    layout: Layout,
}

impl MigrateArgs {
    /// The file the command reads (what its errors name).
    pub fn input(&self) -> &std::path::Path {
        &self.input
    }
}

/// The `migrate` command.
///
/// # Errors
/// When the input cannot be read or is not a valid `.tg` file, or the output cannot be written.
pub fn run(args: &MigrateArgs) -> Result<()> {
    println!(
        "{}",
        pocketsplat_sim::migrate::migrate(&args.input, &args.out, args.layout)?
    );
    Ok(())
}
