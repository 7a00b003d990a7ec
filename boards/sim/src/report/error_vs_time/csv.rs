//! `results.csv`: one row per frame ([`csv`]), and reading it back ([`parse_csv`]) for `--baseline`.

use std::fmt::Write as _;

use anyhow::{bail, Context, Result};

use super::sweep::Row;

/// `results.csv`: a header and one line per row; fields never contain commas or quotes except
/// `detail`, which is quoted.
pub fn csv(rows: &[Row]) -> String {
    let mut out = String::from(CSV_HEADER);
    out.push('\n');
    for r in rows {
        let _ = writeln!(
            out,
            "{},{},{},\"{}\",{},{},{},{:.4},{:.6},{:.6},{:.4},{:.4},{},{},{},{}",
            r.scene,
            r.view,
            r.method,
            r.detail.replace('"', "'"),
            r.kernel,
            r.shadows,
            r.cutoff_px.map(|c| c.to_string()).unwrap_or_default(),
            r.psnr_db,
            r.coverage_mismatch,
            r.holes,
            r.ms,
            r.wall_ms,
            r.nodes_visited,
            r.splats,
            r.arm_instructions
                .map(|n| n.to_string())
                .unwrap_or_default(),
            r.reference
        );
    }
    out
}

/// The columns of `results.csv`.
pub const CSV_HEADER: &str = "scene,view,method,detail,kernel,shadows,cutoff_px,psnr_db,\
     coverage_mismatch,holes,ms,wall_ms,nodes_visited,splats,arm_instructions,reference";

/// The rows of a `results.csv` this report wrote ([`csv`]), read back.
///
/// # Errors
/// When the header is not [`CSV_HEADER`] or a line does not parse.
pub fn parse_csv(text: &str) -> Result<Vec<Row>> {
    let mut lines = text.lines();
    if lines.next() != Some(CSV_HEADER) {
        bail!("not a results.csv of this report (its first line is not `{CSV_HEADER}`)");
    }
    lines
        .enumerate()
        .filter(|(_, l)| !l.is_empty())
        .map(|(i, l)| parse_csv_line(l).with_context(|| format!("line {}", i + 2)))
        .collect()
}

/// One line of `results.csv`: 16 fields, of which only `detail` is quoted.
pub(super) fn parse_csv_line(line: &str) -> Result<Row> {
    let mut fields = Vec::with_capacity(16);
    let (mut field, mut quoted) = (String::new(), false);
    for c in line.chars() {
        match c {
            '"' => quoted = !quoted,
            ',' if !quoted => fields.push(std::mem::take(&mut field)),
            c => field.push(c),
        }
    }
    fields.push(field);
    if fields.len() != 16 || quoted {
        bail!("{} fields, want 16", fields.len());
    }
    let num = |i: usize| -> Result<f64> {
        fields[i]
            .parse()
            .with_context(|| format!("field {}: `{}` is not a number", i + 1, fields[i]))
    };
    let opt = |i: usize| -> Result<Option<u64>> {
        if fields[i].is_empty() {
            Ok(None)
        } else {
            Ok(Some(fields[i].parse().with_context(|| {
                format!("field {}: `{}` is not a count", i + 1, fields[i])
            })?))
        }
    };
    Ok(Row {
        scene: fields[0].clone(),
        view: fields[1].clone(),
        method: fields[2].clone(),
        detail: fields[3].clone(),
        kernel: fields[4].clone(),
        shadows: fields[5].clone(),
        cutoff_px: if fields[6].is_empty() {
            None
        } else {
            Some(num(6)? as f32)
        },
        psnr_db: num(7)?,
        coverage_mismatch: num(8)?,
        holes: num(9)?,
        ms: num(10)?,
        wall_ms: num(11)?,
        nodes_visited: opt(12)?.unwrap_or(0) as u32,
        splats: opt(13)?.unwrap_or(0) as u32,
        arm_instructions: opt(14)?,
        reference: fields[15].clone(),
        file_crc: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_rows_have_as_many_fields_as_the_header() {
        let row = Row {
            scene: "s".into(),
            view: "std".into(),
            method: "brute".into(),
            detail: "every leaf, 12 points".into(),
            kernel: "round".into(),
            shadows: "off".into(),
            cutoff_px: None,
            psnr_db: 30.0,
            coverage_mismatch: 0.01,
            holes: 0.0,
            ms: 1.5,
            wall_ms: 1.6,
            nodes_visited: 12,
            splats: 10,
            arm_instructions: None,
            reference: "-".into(),
            file_crc: None,
        };
        let text = csv(&[row]);
        let mut lines = text.lines();
        let header = lines.next().unwrap().split(',').count();
        let line = lines.next().unwrap();
        // The quoted detail holds one comma.
        assert_eq!(line.split(',').count(), header + 1, "{line}");
    }

    #[test]
    fn results_csv_reads_back_as_it_was_written() {
        let row = |cutoff_px, arm_instructions| Row {
            scene: "big.toml".into(),
            view: "std".into(),
            method: "trigrid".into(),
            detail: "ρ=3 pack of 6 objects, depth ≤ 6".into(),
            kernel: "square".into(),
            shadows: "one-pass".into(),
            cutoff_px,
            psnr_db: 24.3827,
            coverage_mismatch: 0.012_5,
            holes: 0.000_391,
            ms: 3.3113,
            wall_ms: 4.25,
            nodes_visited: 104_549,
            splats: 67_168,
            arm_instructions,
            reference: "ray-cast".into(),
            file_crc: None,
        };
        let rows = vec![row(Some(4.0), Some(39_954_567)), row(None, None)];
        assert_eq!(parse_csv(&csv(&rows)).unwrap(), rows);
        assert!(parse_csv("scene,view\nx,y\n").is_err());
        let bad = csv(&rows).replace("104549", "many");
        let err = format!("{:#}", parse_csv(&bad).unwrap_err());
        assert!(err.contains("line 2") && err.contains("many"), "{err}");
    }
}
