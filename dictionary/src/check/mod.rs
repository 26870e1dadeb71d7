//! Checks on the lowered IR, one submodule per protocol: MAVLink ([`mavlink`]: everything
//! mavgen rejects, and the name collisions that only a Rust backend can hit), the TosNet limits
//! ([`tosnet`]) and the ModRob-1 rules ([`modrob`]), plus the limits of the links that carry
//! dictionary messages ([`Carrier`]). Every problem is reported; nothing stops at the first.

pub mod mavlink;
#[cfg(feature = "toml")]
pub mod modrob;
#[cfg(feature = "toml")]
pub mod tosnet;

use crate::diag::{Code, Diagnostics, Span};
use crate::ir::Ir;

/// The largest payload.
pub const MAX_PAYLOAD: usize = 255;
/// The most fields a message may have.
pub const MAX_FIELDS: usize = 64;

/// A link protocol that carries dictionary messages and limits them further.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Carrier {
    /// NDLCom: the first payload byte is the message id, the wire layout follows, 255 bytes
    /// in all.
    Ndlcom,
}

impl std::str::FromStr for Carrier {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "ndlcom" => Ok(Carrier::Ndlcom),
            _ => Err(format!("unknown carrier `{s}` (known: ndlcom)")),
        }
    }
}

/// Reports every message `carrier` cannot carry.
pub fn check_carrier(ir: &Ir, carrier: Carrier, diags: &mut Diagnostics) {
    match carrier {
        Carrier::Ndlcom => {
            for msg in ir.modules.iter().flat_map(|m| &m.messages) {
                let Some(span) = msg.span.clone() else {
                    continue;
                };
                if msg.id > 255 {
                    diags.report(
                        Code::CarrierIdTooLarge,
                        msg.id_span.clone().unwrap_or(span),
                        format!(
                            "message `{}` has id {}, which NDLCom cannot carry",
                            msg.name.wire, msg.id
                        ),
                        "id over 255",
                    );
                } else if msg.max_len == MAX_PAYLOAD {
                    diags.report(
                        Code::CarrierPayloadTooLong,
                        span,
                        format!(
                            "message `{}` is {} bytes long; with its id byte it exceeds NDLCom's 255-byte payload",
                            msg.name.wire, msg.max_len
                        ),
                        "too long for NDLCom",
                    );
                }
            }
        }
    }
}

/// Reports every problem in `ir`.
pub fn check(ir: &Ir, diags: &mut Diagnostics) {
    mavlink::check(ir, diags);
    #[cfg(feature = "toml")]
    {
        tosnet::check(&ir.rings, diags);
        modrob::check(&ir.modrob, &ir.robots, diags);
    }
}

/// Reports a second definition at `span`, with a note at the `first`.
pub(crate) fn report_dup(
    diags: &mut Diagnostics,
    code: Code,
    span: Option<Span>,
    first: &Option<Span>,
    message: String,
) {
    let Some(span) = span else { return };
    let d = diags.report(code, span, message, "defined again here");
    if let Some(first) = first {
        d.notes.push((first.clone(), "first defined here".into()));
    }
}
