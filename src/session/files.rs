//! Files on disk as a ROS 2 user expects them: a recording is never overwritten unless asked,
//! a new recording is named from its start time as rosbag2 names one, and an output file is
//! either whole or absent.

use anyhow::{Context as _, Result, bail};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Reads a whole file, naming it in the error.
pub fn read_file(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))
}

/// Refuses to replace an existing recording, as `ros2 bag record` does: data is never
/// destroyed unless `overwrite` asks for it.
pub fn refuse_existing_recording(path: &Path, overwrite: bool) -> Result<()> {
    if !overwrite && path.exists() {
        bail!(super::Refusal::RecordingExists {
            path: path.to_path_buf()
        });
    }
    Ok(())
}

/// Refuses an output that is one of the command's inputs: the same file by any path (the same
/// path, a relative one, a symbolic or hard link). Writing it would destroy the input, whether
/// it is a recording or a log. An output that does not exist yet is no input.
pub fn refuse_output_over_input(output: &Path, inputs: &[&Path]) -> Result<()> {
    for input in inputs {
        if same_file(output, input) {
            bail!(super::Refusal::OutputIsInput {
                output: output.to_path_buf(),
                input: input.to_path_buf(),
            });
        }
    }
    Ok(())
}

/// Refuses to print to a standard output that is one of the inputs (`terzaghi fit log.csv >>
/// log.csv`), as `cat` does: the input would grow while it is read, or is already emptied by
/// the shell's `>`.
pub fn refuse_stdout_over_input(inputs: &[&Path]) -> Result<()> {
    for input in inputs {
        if stdout_is(input) {
            bail!(super::Refusal::StdoutIsInput {
                input: input.to_path_buf(),
            });
        }
    }
    Ok(())
}

/// Whether `a` and `b` name one existing file.
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(x), Ok(y)) => same_metadata(&x, &y, a, b),
        _ => false,
    }
}

#[cfg(unix)]
fn same_metadata(x: &std::fs::Metadata, y: &std::fs::Metadata, _: &Path, _: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    x.dev() == y.dev() && x.ino() == y.ino()
}

#[cfg(not(unix))]
fn same_metadata(_: &std::fs::Metadata, _: &std::fs::Metadata, a: &Path, b: &Path) -> bool {
    matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y)
}

#[cfg(unix)]
fn stdout_is(path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    let (Ok(out), Ok(input)) = (std::fs::metadata("/dev/stdout"), std::fs::metadata(path)) else {
        return false;
    };
    out.is_file() && out.dev() == input.dev() && out.ino() == input.ino()
}

#[cfg(not(unix))]
fn stdout_is(_: &Path) -> bool {
    false
}

/// A recording's name from its start time, as rosbag2 names one: `terzaghi_YYYY_MM_DD-HH_MM_SS.mcap`
/// (UTC).
pub fn recording_name(unix_s: u64) -> PathBuf {
    // Days since 1970-01-01 to a civil date (Howard Hinnant's algorithm).
    let days = (unix_s / 86_400) as i64;
    let secs = unix_s % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "terzaghi_{y:04}_{m:02}_{d:02}-{:02}_{:02}_{:02}.mcap",
        secs / 3600,
        secs / 60 % 60,
        secs % 60
    )
    .into()
}

/// Writes a file through a temporary beside it and renames it into place, so that a failure
/// leaves no partial file behind. A path that is not a regular file (`/dev/null`, a FIFO, a
/// terminal) is written in place: renaming over it would replace the device with a file.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> Result<()>,
) -> Result<()> {
    if std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
        let file = std::fs::OpenOptions::new()
            .write(true)
            .open(path)
            .with_context(|| cannot_write(path))?;
        let mut w = std::io::BufWriter::new(file);
        write(&mut w)?;
        return w.flush().with_context(|| cannot_write(path));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .with_context(|| format!("{} is not a file path", path.display()))?;
    let tmp = dir.join(format!(
        ".{}.tmp{}",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| {
        let file = std::fs::File::create(&tmp).with_context(|| cannot_write(path))?;
        let mut w = std::io::BufWriter::new(file);
        write(&mut w)?;
        w.flush().with_context(|| cannot_write(path))?;
        std::fs::rename(&tmp, path).with_context(|| cannot_write(path))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// The failure to write an output (`cannot write PATH`): the run failed, not its input.
pub fn cannot_write(path: &Path) -> super::Failure {
    super::Failure(format!("cannot write {}", path.display()))
}

/// Writes `text` to `path` whole or not at all.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    write_atomically(path, |w| Ok(w.write_all(text.as_bytes())?))
}

/// Whether `path` begins as an MCAP file does.
pub fn is_mcap(path: &Path) -> Result<bool> {
    use std::io::Read;
    let mut magic = [0u8; 5];
    let mut f =
        std::fs::File::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let n = f.read(&mut magic).unwrap_or(0);
    Ok(n == 5 && &magic == b"\x89MCAP")
}

/// A CSV table of `text` (the file `name`) as the project's readers take one: fields trimmed,
/// lines from `#` on comments, its header read (an error naming the file where there is none).
pub fn csv_table<'t>(name: &str, text: &'t str) -> Result<(csv::Reader<&'t [u8]>, Vec<String>)> {
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_reader(text.as_bytes());
    let headers = rdr
        .headers()
        .with_context(|| format!("{name}: no CSV header"))?
        .iter()
        .map(str::to_string)
        .collect();
    Ok((rdr, headers))
}

/// The columns of `file`'s header (its first line that is not a `#` comment), read from its
/// first 64 kB alone (a recording may be gigabytes, and is not text); `None` where it cannot be
/// read or has no such line. What tells a test's kind by its columns.
pub fn header_columns(file: &Path) -> Option<Vec<String>> {
    use std::io::{BufRead, Read};
    let f = std::fs::File::open(file).ok()?;
    let header = std::io::BufReader::new(f.take(64 * 1024))
        .lines()
        .map_while(Result::ok)
        .find(|l| !l.starts_with('#'))?;
    Some(header.split(',').map(|c| c.trim().to_string()).collect())
}

/// The field `text` of column `what` on line `line` of the file `name` as a finite number, or
/// an error naming the file, the line and the value.
pub fn csv_number(name: &str, line: usize, what: &str, text: &str) -> Result<f64> {
    let v: f64 = text
        .parse()
        .map_err(|_| anyhow::anyhow!("{name} line {line}: {what} is {text:?}, not a number"))?;
    if !v.is_finite() {
        bail!("{name} line {line}: {what} is {v}");
    }
    Ok(v)
}

/// Writes `text` to stdout; a closed pipe (`| head`) ends the command quietly.
pub fn print_out(text: &str) -> Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|_| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        r => r.context(crate::error::Failure(
            "cannot write to standard output".into(),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::FileTypeExt;

    /// `-o /dev/null` writes to the device: it stays a device (renaming a temporary over it
    /// would leave every program on the machine a regular file for /dev/null).
    #[test]
    fn a_device_is_written_in_place_and_stays_a_device() {
        write_text(Path::new("/dev/null"), "rows\n").unwrap();
        let m = std::fs::metadata("/dev/null").unwrap();
        assert!(m.file_type().is_char_device(), "{m:?}");
        // A regular file is still replaced whole.
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.csv");
        write_text(&p, "a\n").unwrap();
        write_text(&p, "b\n").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "b\n");
    }
}
