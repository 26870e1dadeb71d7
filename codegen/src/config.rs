//! The build-time API, shaped like `prost-build`: a builder whose last call writes.

use std::path::{Path, PathBuf};

use proc_macro2::TokenStream;
use quote::quote;

use crate::backend::ident;
use crate::backend::mavlink::{self, SerdeMode};
#[cfg(feature = "toml")]
use crate::backend::{modrob, tosnet};
use crate::diag::Failed;
use crate::format;
use crate::write::{self, GeneratedFile};
use crate::{Carrier, Checked, Diagnostic};

/// Configures and runs the generator.
///
/// ```no_run
/// // build.rs
/// ferrolink_codegen::Config::new()
///     .input("definitions/mavlink/usv.xml")
///     .compile()
///     .unwrap_or_else(|e| panic!("{e}"));
/// ```
#[derive(Debug, Clone, Default)]
pub struct Config {
    inputs: Vec<PathBuf>,
    out_dir: Option<PathBuf>,
    file_name: Option<String>,
    serde: SerdeMode,
    carriers: Vec<Carrier>,
    module_features: bool,
}

/// The result of [`Config::generate`]: file contents, nothing written yet.
#[derive(Debug, Clone)]
pub struct Generated {
    /// The files, relative to the output directory.
    pub files: Vec<GeneratedFile>,
    /// Every dictionary file read, includes too.
    pub read: Vec<PathBuf>,
    /// Warnings.
    pub warnings: Vec<Diagnostic>,
}

/// How the modules are laid out.
#[derive(Debug, Clone, Copy)]
enum Layout {
    /// One file with an inline `pub mod` per dictionary file, for `include!`.
    Single,
    /// `mod.rs` plus one file per dictionary file, for checking in.
    Modules,
}

impl Config {
    /// A configuration with no inputs.
    ///
    /// ```
    /// let config = ferrolink_codegen::Config::new();
    /// ```
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a dictionary file: a MAVLink XML dialect (its includes are read too) or, ending in
    /// `.toml`, a TosNet register map.
    ///
    /// ```
    /// ferrolink_codegen::Config::new()
    ///     .input("common.xml")
    ///     .input("my_dialect.xml")
    ///     .input("my_ring.toml");
    /// ```
    pub fn input(&mut self, path: impl AsRef<Path>) -> &mut Self {
        self.inputs.push(path.as_ref().to_path_buf());
        self
    }

    /// Where [`Config::compile`] writes; `$OUT_DIR` by default.
    ///
    /// ```
    /// ferrolink_codegen::Config::new().out_dir("src/generated");
    /// ```
    pub fn out_dir(&mut self, dir: impl AsRef<Path>) -> &mut Self {
        self.out_dir = Some(dir.as_ref().to_path_buf());
        self
    }

    /// The name of the file [`Config::compile`] writes; `ferrolink.rs` by default.
    ///
    /// ```
    /// ferrolink_codegen::Config::new().file_name("dialects.rs");
    /// ```
    pub fn file_name(&mut self, name: impl Into<String>) -> &mut Self {
        self.file_name = Some(name.into());
        self
    }

    /// Whether generated types implement serde's traits, in pymavlink's `to_dict()` JSON form.
    /// Off by default; the crate holding the code then depends on `ferrolink-runtime` with its
    /// `serde` feature.
    ///
    /// ```
    /// use ferrolink_codegen::{Config, SerdeMode};
    /// Config::new().serde(SerdeMode::Feature("serde".into()));
    /// ```
    pub fn serde(&mut self, mode: SerdeMode) -> &mut Self {
        self.serde = mode;
        self
    }

    /// Also checks that every message fits `carrier` (e.g. NDLCom's one-byte message id).
    ///
    /// ```
    /// use ferrolink_codegen::{Carrier, Config};
    ///
    /// let mut config = Config::new();
    /// config.input("dialect.xml").carrier(Carrier::Ndlcom);
    /// ```
    pub fn carrier(&mut self, carrier: Carrier) -> &mut Self {
        if !self.carriers.contains(&carrier) {
            self.carriers.push(carrier);
        }
        self
    }

    /// Puts each dictionary file's module behind the cargo feature of its name (`common.xml`:
    /// `#[cfg(feature = "common")] pub mod common;`), so that a crate holding many dialects
    /// compiles only those enabled. The crate's features must enable what each one includes.
    ///
    /// ```
    /// ferrolink_codegen::Config::new().module_features(true);
    /// ```
    pub fn module_features(&mut self, on: bool) -> &mut Self {
        self.module_features = on;
        self
    }

    /// The `#[cfg(feature = ..)]` of module `name`, when modules are behind features.
    fn module_cfg(&self, name: &str) -> TokenStream {
        if self.module_features {
            let feature = name.trim_start_matches("r#");
            quote!(#[cfg(feature = #feature)])
        } else {
            quote!()
        }
    }

    fn run(&self) -> Result<Checked, Failed> {
        crate::load_for(&self.inputs, &self.carriers)
    }

    fn inputs_label(&self) -> String {
        let names: Vec<String> = self
            .inputs
            .iter()
            .map(|p| {
                p.file_name().map_or_else(
                    || p.display().to_string(),
                    |n| n.to_string_lossy().into_owned(),
                )
            })
            .collect();
        names.join(", ")
    }

    fn render(&self, layout: Layout) -> Result<Generated, Failed> {
        let checked = self.run()?;
        let header = format::header(&self.inputs_label());
        #[allow(unused_mut)]
        let mut modules = mavlink::emit(&checked.ir, &self.serde);
        #[cfg(feature = "toml")]
        {
            modules.extend(tosnet::emit(&checked.ir));
            modules.extend(modrob::emit(&checked.ir));
        }
        let files = match layout {
            Layout::Single => {
                let mods = modules.iter().map(|(name, tokens)| {
                    let cfg = self.module_cfg(name);
                    let inline = module(name, tokens, true);
                    quote!(#cfg #inline)
                });
                let text = format::render(quote!(#( #mods )*));
                vec![GeneratedFile {
                    name: self
                        .file_name
                        .clone()
                        .unwrap_or_else(|| "ferrolink.rs".into()),
                    content: format!("{header}{text}"),
                }]
            }
            Layout::Modules => {
                let decls = modules.iter().map(|(name, _)| {
                    let id = ident(name);
                    let cfg = self.module_cfg(name);
                    quote!(#cfg pub mod #id;)
                });
                let mut files = vec![GeneratedFile {
                    name: "mod.rs".into(),
                    content: format!("{header}{}", format::render(quote!(#( #decls )*))),
                }];
                for (name, tokens) in &modules {
                    let body = module(name, tokens, false);
                    files.push(GeneratedFile {
                        name: format!("{}.rs", name.trim_start_matches("r#")),
                        content: format!("{header}{}", format::render(body)),
                    });
                }
                files
            }
        };
        Ok(Generated {
            files,
            read: checked.read,
            warnings: checked.warnings,
        })
    }

    /// Generates one file holding an inline module per dictionary file. Pure: nothing is
    /// written.
    pub fn generate(&self) -> Result<Generated, Failed> {
        self.render(Layout::Single)
    }

    /// Generates `mod.rs` plus one file per dictionary file, for a checked-in crate. Pure.
    pub fn generate_modules(&self) -> Result<Generated, Failed> {
        self.render(Layout::Modules)
    }

    /// For `build.rs`: generates, writes to the output directory if the content changed, prints
    /// `cargo:rerun-if-changed` for every file read (includes too) and each warning as
    /// `cargo:warning`.
    pub fn compile(&self) -> Result<(), Failed> {
        let result = self.generate();
        // Rerun on any input change even when this run failed, so a fix is picked up.
        for input in &self.inputs {
            println!("cargo:rerun-if-changed={}", input.display());
        }
        let generated = result?;
        for path in &generated.read {
            println!("cargo:rerun-if-changed={}", path.display());
        }
        for w in &generated.warnings {
            for line in w.to_string().lines() {
                println!("cargo:warning={line}");
            }
        }
        let dir = match &self.out_dir {
            Some(d) => d.clone(),
            None => std::env::var_os("OUT_DIR")
                .map(PathBuf::from)
                .unwrap_or_else(|| PathBuf::from(".")),
        };
        write::write_all(&dir, &generated.files).map_err(|e| io_failure(&dir, e))?;
        Ok(())
    }
}

fn io_failure(dir: &Path, e: std::io::Error) -> Failed {
    let file = crate::diag::SourceFile::new(dir, String::new());
    let mut d = crate::diag::Diagnostics::default();
    d.report(
        crate::diag::Code::Io,
        crate::diag::Span::new(&file, 0, 0),
        format!("cannot write to {}: {e}", dir.display()),
        "",
    );
    Failed(d.into_vec())
}

/// Wraps a module's items: inline (`pub mod x { ... }`) or as a file's top level.
fn module(name: &str, tokens: &TokenStream, inline: bool) -> TokenStream {
    let attrs = quote!();
    if inline {
        let id = ident(name);
        quote!(pub mod #id { #attrs #tokens })
    } else {
        quote!(#attrs #tokens)
    }
}
