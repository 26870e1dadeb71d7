//! `ferrolink`: generate bindings (MAVLink XML dialects, TosNet register maps), check
//! dictionaries, dump the IR, and work with NDLCom traffic and ModRob-1 messages.

mod dialect;
mod diff;
mod mavlink;
#[cfg(feature = "parquet")]
mod mavlink_export;
mod mavlink_ftp;
mod mavlink_services;
mod mavlink_stats;
#[cfg(feature = "vehicle")]
mod mavlink_vehicle;
mod modrob;
mod ndlcom;
mod schemes;
mod tosnet;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "ferrolink",
    version,
    about = "Message dictionaries to fast, safe Rust"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Generate Rust bindings: `mod.rs` plus one module per dictionary file.
    #[cfg(feature = "generate")]
    Generate {
        /// Dictionary files: MAVLink XML (their includes are read too), TosNet register maps and
        /// ModRob-1 module dictionaries and robots (TOML).
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Only report whether the output directory is up to date (exit 1 if not).
        #[arg(long)]
        check: bool,
        /// serde support: derive behind this cargo feature of the crate holding the code.
        #[arg(long, value_name = "FEATURE", conflicts_with = "serde_always")]
        serde_feature: Option<String>,
        /// serde support: always derive.
        #[arg(long)]
        serde_always: bool,
        /// Also check that every message fits this carrier (`ndlcom`: ids below 256).
        #[arg(long, value_name = "CARRIER")]
        carrier: Vec<ferrolink_dictionary::Carrier>,
        /// Put each module behind the cargo feature of its name (`#[cfg(feature = "common")]`).
        #[arg(long)]
        module_features: bool,
    },
    /// Report every problem in the dictionaries; exit 1 on errors.
    Check {
        /// Dictionary files.
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        /// Also check that every message fits this carrier (`ndlcom`: ids below 256).
        #[arg(long, value_name = "CARRIER")]
        carrier: Vec<ferrolink_dictionary::Carrier>,
    },
    /// MAVLink: route between endpoints, dump telemetry logs.
    #[command(subcommand)]
    Mavlink(mavlink::Command),
    /// NDLCom frames: encode, decode, bridge, log, export.
    #[command(subcommand)]
    Ndlcom(ndlcom::Command),
    /// ModRob-1 messages: encode and decode CAN-1, UART.B-1, SPI-1 and Ethernet-1.
    #[command(subcommand)]
    Modrob(modrob::Command),
    /// TosNet: the cycle-rate model against a simulated ring.
    #[command(subcommand)]
    Tosnet(tosnet::Command),
    /// Write a static documentation site for the dictionaries: DIR/index.html, a page per file,
    /// an offline search and DIR/dictionary.json.
    Docs {
        /// Dictionary files.
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        /// Output directory (created if needed).
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
    },
    /// Write Wireshark dissectors in Lua for the dictionaries' protocols.
    Wireshark {
        /// Dictionary files.
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        /// The Lua file to write.
        #[arg(long, value_name = "FILE.lua")]
        out: PathBuf,
    },
    /// Compare two versions of dictionaries: what breaks on the wire, in meaning, or in the
    /// generated Rust (exit 1 with findings at or above --fail-on, 2 on invalid input).
    Diff(diff::DiffArgs),
    /// Print the lowered IR as JSON.
    Ir {
        /// Dictionary files.
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
    },
}

fn main() -> ExitCode {
    #[cfg(feature = "zenoh")]
    ferrolink_zenoh::one_worker_thread();
    let cli = Cli::parse();
    let result = run(cli.command);
    // Log lines queued on the way (a link's retries, say) go out first, unless nobody reads them.
    let _ = ferrolink_io::printer::flush_stderr(ferrolink_io::printer::FLUSH_PATIENCE);
    match result {
        Ok(code) => code,
        // Whoever read our output stopped reading (`| head`): stop quietly, as Unix tools do.
        Err(e) if is_broken_pipe(e.as_ref()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}

/// Whether `e`, or an error it wraps, is a write to a closed pipe.
fn is_broken_pipe(e: &(dyn std::error::Error + 'static)) -> bool {
    let mut next = Some(e);
    while let Some(e) = next {
        if e.downcast_ref::<std::io::Error>()
            .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
        {
            return true;
        }
        if let Some(json) = e.downcast_ref::<serde_json::Error>() {
            if json.io_error_kind() == Some(std::io::ErrorKind::BrokenPipe) {
                return true;
            }
        }
        next = e.source();
    }
    false
}

/// The `encode` commands' loop: every non-empty line of stdin through `encode`, each frame printed
/// as hex; a line that does not encode is reported as `stdin:N: why` and makes the exit status
/// 1, and the others are still encoded.
fn encode_lines(
    mut encode: impl FnMut(usize, &str) -> Result<Vec<u8>, String>,
) -> Result<ExitCode, Box<dyn std::error::Error>> {
    use std::io::{BufRead, Write};
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let mut failed = false;
    for (n, line) in std::io::stdin().lock().lines().enumerate() {
        let line = line?;
        if line.trim().is_empty() {
            continue;
        }
        match encode(n, &line) {
            Ok(frame) => writeln!(out, "{}", hex::encode(frame))?,
            Err(e) => {
                out.flush()?;
                eprintln!("stdin:{}: {e}", n + 1);
                failed = true;
            }
        }
    }
    out.flush()?;
    Ok(if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

fn print_warnings(warnings: &[ferrolink_dictionary::Diagnostic]) {
    for w in warnings {
        eprintln!("{w}\n");
    }
}

fn run(command: Command) -> Result<ExitCode, Box<dyn std::error::Error>> {
    match command {
        #[cfg(feature = "generate")]
        Command::Generate {
            inputs,
            out,
            check,
            serde_feature,
            serde_always,
            carrier,
            module_features,
        } => {
            let mut config = ferrolink_codegen::Config::new();
            config.module_features(module_features);
            config.serde(match (serde_feature, serde_always) {
                (Some(f), _) => ferrolink_codegen::SerdeMode::Feature(f),
                (None, true) => ferrolink_codegen::SerdeMode::Always,
                (None, false) => ferrolink_codegen::SerdeMode::Off,
            });
            for i in &inputs {
                config.input(i);
            }
            for c in carrier {
                config.carrier(c);
            }
            let generated = config.generate_modules()?;
            print_warnings(&generated.warnings);
            if check {
                let stale = ferrolink_dictionary::write::stale(&out, &generated.files);
                if stale.is_empty() {
                    eprintln!("{} is up to date", out.display());
                    return Ok(ExitCode::SUCCESS);
                }
                eprintln!("stale in {}: {}", out.display(), stale.join(", "));
                return Ok(ExitCode::FAILURE);
            }
            let written = ferrolink_dictionary::write::write_all(&out, &generated.files)?;
            eprintln!(
                "{} file(s) in {}, {} changed",
                generated.files.len(),
                out.display(),
                written.len()
            );
            Ok(ExitCode::SUCCESS)
        }
        Command::Check { inputs, carrier } => {
            match ferrolink_dictionary::load_for(&inputs, &carrier) {
                Ok(checked) => {
                    print_warnings(&checked.warnings);
                    let ir = &checked.ir;
                    let messages: usize = ir.modules.iter().map(|m| m.messages.len()).sum();
                    let mut summary = format!(
                        "ok: {} file(s), {messages} message(s), {} enum(s)",
                        checked.read.len(),
                        ir.enums.len(),
                    );
                    if !ir.rings.is_empty() {
                        let nodes: usize = ir.rings.iter().map(|r| r.nodes.len()).sum();
                        let registers: usize = ir.rings.iter().map(|r| r.enabled_registers()).sum();
                        summary.push_str(&format!(
                            ", {} ring(s) with {nodes} node(s) and {registers} enabled register(s)",
                            ir.rings.len()
                        ));
                    }
                    if !ir.modrob.is_empty() {
                        let vis: usize = ir.modrob.iter().map(|m| m.vi_count()).sum();
                        summary.push_str(&format!(
                            ", {} ModRob-1 dictionaries with {vis} variable(s)",
                            ir.modrob.len()
                        ));
                    }
                    for robot in &ir.robots {
                        summary.push_str(&format!(
                            ", robot `{}` with {} module(s) on {} network(s)",
                            robot.name.wire,
                            robot.instances.len(),
                            robot.networks.len()
                        ));
                    }
                    eprintln!("{summary}, {} warning(s)", checked.warnings.len());
                    Ok(ExitCode::SUCCESS)
                }
                Err(failed) => {
                    eprintln!("{failed}");
                    Ok(ExitCode::FAILURE)
                }
            }
        }
        Command::Mavlink(command) => mavlink::run(command),
        Command::Ndlcom(command) => ndlcom::run(command),
        Command::Modrob(command) => modrob::run(command),
        Command::Tosnet(command) => tosnet::run(command),
        Command::Docs { inputs, out } => {
            let checked = ferrolink_dictionary::load(&inputs)?;
            print_warnings(&checked.warnings);
            let files = ferrolink_tools::docs::generate(&checked.ir)?;
            std::fs::create_dir_all(&out)?;
            let written = ferrolink_dictionary::write::write_all(&out, &files)?;
            eprintln!(
                "{} file(s) in {}, {} changed; open {}",
                files.len(),
                out.display(),
                written.len(),
                out.join("index.html").display()
            );
            Ok(ExitCode::SUCCESS)
        }
        Command::Wireshark { inputs, out } => {
            let checked = ferrolink_dictionary::load(&inputs)?;
            print_warnings(&checked.warnings);
            let lua = ferrolink_tools::wireshark::generate(&checked.ir)?;
            ferrolink_dictionary::write::write_if_changed(&out, &lua)?;
            eprintln!("wrote {}", out.display());
            Ok(ExitCode::SUCCESS)
        }
        Command::Diff(args) => diff::run(args),
        Command::Ir { inputs } => {
            let checked = ferrolink_dictionary::load(&inputs)?;
            print_warnings(&checked.warnings);
            let mut out = std::io::stdout().lock();
            serde_json::to_writer_pretty(&mut out, &checked.ir)?;
            std::io::Write::write_all(&mut out, b"\n")?;
            Ok(ExitCode::SUCCESS)
        }
    }
}
