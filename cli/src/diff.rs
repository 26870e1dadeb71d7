//! `ferrolink diff OLD NEW`: what a dictionary change breaks, with OLD from files, directories
//! or a git revision.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

use clap::{Args, ValueEnum};
use ferrolink_tools::diff::{self, Category, Format};

/// `ferrolink diff`'s arguments.
#[derive(Args)]
pub struct DiffArgs {
    /// The old and the new dictionaries: files or directories (every `.xml` and `.toml` in them).
    /// With `--against`, only NEW.
    #[arg(required = true, num_args = 1..=2, value_names = ["OLD", "NEW"])]
    paths: Vec<PathBuf>,
    /// Take OLD from this git revision: the same paths as NEW, as committed there.
    #[arg(long, value_name = "GIT_REF")]
    against: Option<String>,
    /// Output form.
    #[arg(long, value_enum, default_value = "text")]
    format: FormatArg,
    /// Exit 1 when a finding of this category or a worse one exists.
    #[arg(long, value_enum, default_value = "wire")]
    fail_on: FailOn,
}

#[derive(Clone, Copy, ValueEnum)]
enum FormatArg {
    Text,
    Json,
    Github,
}

#[derive(Clone, Copy, ValueEnum)]
enum FailOn {
    Wire,
    Semantic,
    Api,
}

/// Exit status 2: an input could not be read or is invalid.
const BAD_INPUT: u8 = 2;

pub fn run(args: DiffArgs) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let checkout;
    let (old, new, old_prefix) = match (&args.against, args.paths.as_slice()) {
        (Some(rev), [new]) => {
            checkout = tempfile::tempdir()?;
            match from_git(rev, new, checkout.path()) {
                Ok(old) => (
                    old,
                    new.clone(),
                    Some((checkout.path().to_path_buf(), rev.clone())),
                ),
                Err(e) => {
                    eprintln!("error: {e}");
                    return Ok(ExitCode::from(BAD_INPUT));
                }
            }
        }
        (None, [old, new]) => (old.clone(), new.clone(), None),
        (Some(_), _) => {
            eprintln!("error: with --against, give only NEW");
            return Ok(ExitCode::from(BAD_INPUT));
        }
        (None, _) => {
            eprintln!("error: give OLD and NEW (or NEW with --against GIT_REF)");
            return Ok(ExitCode::from(BAD_INPUT));
        }
    };
    let (Some(old_ir), Some(new_ir)) = (load(&old), load(&new)) else {
        return Ok(ExitCode::from(BAD_INPUT));
    };
    let mut findings = diff::diff(&old_ir, &new_ir);
    // Positions in a checked-out revision read as `REV:path`.
    if let Some((dir, rev)) = old_prefix {
        for at in findings.iter_mut().filter_map(|f| f.old_at.as_mut()) {
            if let Ok(rel) = Path::new(&at.file).strip_prefix(&dir) {
                at.file = format!("{rev}:{}", rel.display());
            }
        }
    }
    let format = match args.format {
        FormatArg::Text => Format::Text,
        FormatArg::Json => Format::Json,
        FormatArg::Github => Format::Github,
    };
    {
        use std::io::Write as _;
        let mut out = std::io::stdout().lock();
        write!(out, "{}", diff::render(&findings, format))?;
        out.flush()?;
    }
    let fail_on = match args.fail_on {
        FailOn::Wire => Category::Wire,
        FailOn::Semantic => Category::Semantic,
        FailOn::Api => Category::Api,
    };
    Ok(if diff::fails(&findings, fail_on) {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

/// Loads one side, printing every problem; `None` if it cannot be read or is invalid.
fn load(path: &Path) -> Option<ferrolink_dictionary::ir::Ir> {
    let inputs = match dictionary_files(path) {
        Ok(inputs) if !inputs.is_empty() => inputs,
        Ok(_) => {
            eprintln!(
                "error: {} holds no .xml or .toml dictionary",
                path.display()
            );
            return None;
        }
        Err(e) => {
            eprintln!("error: cannot read {}: {e}", path.display());
            return None;
        }
    };
    match ferrolink_dictionary::load(&inputs) {
        Ok(checked) => Some(checked.ir),
        Err(failed) => {
            eprintln!("{failed}");
            None
        }
    }
}

/// A file as itself; a directory as every `.xml` and `.toml` under it, sorted.
fn dictionary_files(path: &Path) -> std::io::Result<Vec<PathBuf>> {
    if !path.is_dir() {
        std::fs::metadata(path)?;
        return Ok(vec![path.to_path_buf()]);
    }
    let mut files = Vec::new();
    let mut dirs = vec![path.to_path_buf()];
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir)? {
            let p = entry?.path();
            if p.is_dir() {
                dirs.push(p);
            } else if matches!(p.extension().and_then(|e| e.to_str()), Some("xml" | "toml")) {
                files.push(p);
            }
        }
    }
    files.sort();
    Ok(files)
}

/// Writes `path` as committed at `rev` into `into`, keeping its path relative to the repository,
/// and returns where it landed. A file brings its whole directory (its includes and the
/// dictionaries a robot names).
fn from_git(rev: &str, path: &Path, into: &Path) -> Result<PathBuf, String> {
    let abs = path
        .canonicalize()
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let dir = if abs.is_dir() {
        abs.clone()
    } else {
        abs.parent().map(Path::to_path_buf).unwrap_or_default()
    };
    let git = |cwd: &Path, args: &[&str]| -> Result<Vec<u8>, String> {
        let out = Command::new("git")
            .arg("-C")
            .arg(cwd)
            .args(args)
            .output()
            .map_err(|e| format!("cannot run git: {e}"))?;
        if !out.status.success() {
            return Err(format!(
                "git {}: {}",
                args.join(" "),
                String::from_utf8_lossy(&out.stderr).trim()
            ));
        }
        Ok(out.stdout)
    };
    let top = git(&dir, &["rev-parse", "--show-toplevel"])?;
    let top = PathBuf::from(String::from_utf8_lossy(&top).trim());
    let rel_dir = dir
        .strip_prefix(&top)
        .map_err(|_| format!("{} is not inside {}", dir.display(), top.display()))?;
    let spec = if rel_dir.as_os_str().is_empty() {
        ".".to_owned()
    } else {
        format!("{}/", rel_dir.display())
    };
    let listing = git(&top, &["ls-tree", "-r", "--name-only", rev, "--", &spec])?;
    let names: Vec<String> = String::from_utf8_lossy(&listing)
        .lines()
        .map(str::to_owned)
        .collect();
    if names.is_empty() {
        return Err(format!("{} does not exist at {rev}", rel_dir.display()));
    }
    for name in names {
        let bytes = git(&top, &["show", &format!("{rev}:{name}")])?;
        let dest = into.join(&name);
        if let Some(parent) = dest.parent() {
            std::fs::create_dir_all(parent).map_err(|e| e.to_string())?;
        }
        std::fs::write(&dest, bytes).map_err(|e| e.to_string())?;
    }
    let rel = abs.strip_prefix(&top).unwrap_or(&abs);
    let old = into.join(rel);
    if !old.exists() {
        return Err(format!("{} does not exist at {rev}", rel.display()));
    }
    Ok(old)
}
