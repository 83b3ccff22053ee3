//! Measurement tables as files: a Markdown and a CSV file per command, each headed by what
//! is needed to reproduce and compare it (the exact command line, the commit, the date and
//! the machine). Every `bench` subcommand and `stress` write through here.

use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Where a table was measured: one `key: value` line each.
#[derive(Clone, Debug)]
pub struct Provenance {
    pub command: String,
    /// `git rev-parse --short HEAD`, `-dirty` when the work tree has changes, `unknown`
    /// outside a git checkout.
    pub commit: String,
    /// UTC, ISO 8601.
    pub date: String,
    /// CPU model and core count, memory, and the GPU adapter when the GPU backend ran.
    pub machine: String,
}

impl Provenance {
    /// This process, now; `gpu` names the adapter when the GPU backend ran.
    pub fn here(gpu: Option<&str>) -> Self {
        let command = std::env::args()
            .map(|a| shell_word(&a))
            .collect::<Vec<_>>()
            .join(" ");
        let mut machine = format!("{}, {} cores", cpu_model(), cores());
        if let Some(gib) = memory_gib() {
            machine += &format!(", {gib:.1} GiB memory");
        }
        if let Some(gpu) = gpu {
            machine += &format!(", GPU {gpu}");
        }
        Provenance {
            command,
            commit: commit(),
            date: utc_now(),
            machine,
        }
    }

    fn lines(&self) -> [(&'static str, &str); 4] {
        [
            ("command", &self.command),
            ("commit", &self.commit),
            ("date", &self.date),
            ("machine", &self.machine),
        ]
    }
}

/// Writes `dir/stem.md` (the header, then `markdown` as printed) and `dir/stem.csv` (the
/// header as `#` comment lines, then `csv`, or when `None` the rows of every table in
/// `markdown`); returns both paths.
pub fn write(
    dir: &Path,
    stem: &str,
    provenance: &Provenance,
    markdown: &str,
    csv: Option<&str>,
) -> Result<[PathBuf; 2]> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut md = String::new();
    for (key, value) in provenance.lines() {
        md += &format!("- {key}: `{value}`\n");
    }
    md += "\n";
    md += markdown;
    let mut text = String::new();
    for (key, value) in provenance.lines() {
        text += &format!("# {key}: {value}\n");
    }
    match csv {
        Some(csv) => text += csv,
        None => text += &csv_from_markdown(markdown),
    }
    let paths = [
        dir.join(format!("{stem}.md")),
        dir.join(format!("{stem}.csv")),
    ];
    for (path, contents) in paths.iter().zip([md, text]) {
        std::fs::write(path, contents)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(paths)
}

/// The cells of a Markdown table line (`| a | b |`), or `None` for any other line and for
/// the `|---|` rule under a header.
pub fn table_cells(line: &str) -> Option<Vec<&str>> {
    let inner = line.trim().strip_prefix('|')?.strip_suffix('|')?;
    let cells: Vec<&str> = inner.split('|').map(str::trim).collect();
    let rule = cells
        .iter()
        .all(|c| !c.is_empty() && c.chars().all(|ch| matches!(ch, '-' | ':')));
    (!rule).then_some(cells)
}

/// Each Markdown table of `markdown` as CSV rows (its header row first), the tables apart by
/// a blank line; the text between tables (titles, notes) as `#` comment lines.
pub fn csv_from_markdown(markdown: &str) -> String {
    let mut out = String::new();
    let mut in_table = false;
    for line in markdown.lines() {
        if line.trim().starts_with('|') {
            if let Some(cells) = table_cells(line) {
                let quoted: Vec<String> = cells.iter().map(|c| csv_field(c)).collect();
                out += &quoted.join(",");
                out += "\n";
            }
            in_table = true;
            continue;
        }
        if in_table {
            out += "\n";
            in_table = false;
        }
        if !line.trim().is_empty() {
            out += &format!("# {}\n", line.trim());
        }
    }
    out
}

/// A CSV field, quoted when it holds a comma, a quote or a line break (RFC 4180).
fn csv_field(cell: &str) -> String {
    if cell.contains([',', '"', '\n']) {
        format!("\"{}\"", cell.replace('"', "\"\""))
    } else {
        cell.to_owned()
    }
}

/// An argument as a shell would need it to get it back.
fn shell_word(arg: &str) -> String {
    let plain = !arg.is_empty()
        && arg
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c));
    if plain {
        arg.to_owned()
    } else {
        format!("'{}'", arg.replace('\'', r"'\''"))
    }
}

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_owned())
}

fn commit() -> String {
    let Some(hash) = git(&["rev-parse", "--short", "HEAD"]) else {
        return "unknown".into();
    };
    match git(&["status", "--porcelain"]) {
        Some(changes) if !changes.is_empty() => format!("{hash}-dirty"),
        _ => hash,
    }
}

fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|text| {
            text.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, model)| model.trim().to_owned())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_owned())
}

fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// `MemTotal` of /proc/meminfo.
fn memory_gib() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kib: f64 = text
        .lines()
        .find(|l| l.starts_with("MemTotal:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()?;
    Some(kib / (1024.0 * 1024.0))
}

/// Now in UTC as `YYYY-MM-DDTHH:MM:SSZ`.
fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (days, rest) = (secs / 86_400, secs % 86_400);
    let (y, m, d) = civil_from_days(days as i64);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rest / 3600,
        rest % 3600 / 60,
        rest % 60
    )
}

/// The proleptic Gregorian date `days` after 1970-01-01 (H. Hinnant's `civil_from_days`).
fn civil_from_days(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates_fall_on_the_calendar() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(11_016), (2000, 2, 29));
        assert_eq!(civil_from_days(20_784), (2026, 11, 27));
    }

    #[test]
    fn markdown_tables_become_csv_rows_and_notes_comments() {
        let md = "Title\n\n| a | b, c |\n|---|:-:|\n| 1 | \"x\" |\n\nnote\n| z |\n|---|\n";
        assert_eq!(
            csv_from_markdown(md),
            "# Title\na,\"b, c\"\n1,\"\"\"x\"\"\"\n\n# note\nz\n"
        );
    }
}
