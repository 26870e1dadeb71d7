//! The ModRob-1 backend, built with `quote!`: one module per module dictionary and per robot.
//!
//! A dictionary becomes a `const` [`Dictionary`](ferrolink_runtime) table (one entry per VI,
//! sorted), the `INFO` text, a `Var` enum whose discriminants are the VIs, a typed `Vars` struct
//! (an array variable is an `[f32; N]` field) with conversions from and to the engine's value
//! array, and an `Engine` alias with a constructor. A robot becomes its networks, its instances
//! with the leader's stored commands as `const` messages, one MI constant per instance, and the
//! `ROBOT` table the leader engine reads. The logic lives in the runtime; this is data.

use proc_macro2::{Literal, TokenStream};
use quote::quote;

use super::{docs, ident, inner, lit};
use crate::ir::{Direction, Ir, ModrobModule, ModrobVariable, Robot, Setting, Transport};

/// Emits every dictionary and robot of `ir`, in order, as (module name, tokens).
pub fn emit(ir: &Ir) -> Vec<(String, TokenStream)> {
    let modules = ir
        .modrob
        .iter()
        .map(|m| (m.name.rust.clone(), emit_module(m)));
    let robots = ir
        .robots
        .iter()
        .map(|r| (r.name.rust.clone(), emit_robot(ir, r)));
    modules.chain(robots).collect()
}

/// A hexadecimal literal, `0x0110`.
fn hex(v: u32, digits: usize) -> Literal {
    format!("{v:#0w$x}", w = digits + 2)
        .parse()
        .expect("a hex literal")
}

/// An `f32` expression for `v`: a literal, or `f32::INFINITY` and friends.
fn float(v: f64) -> TokenStream {
    if v.is_nan() {
        quote!(f32::NAN)
    } else if v == f64::INFINITY {
        quote!(f32::INFINITY)
    } else if v == f64::NEG_INFINITY {
        quote!(f32::NEG_INFINITY)
    } else {
        let l = Literal::f32_unsuffixed(v as f32);
        quote!(#l)
    }
}

fn file_name(path: &str) -> &str {
    path.rsplit(['/', '\\']).next().unwrap_or(path)
}

fn uuid(uuid: &Option<[u8; 16]>) -> TokenStream {
    match uuid {
        Some(bytes) => {
            let b = bytes.iter().map(|b| hex((*b).into(), 2));
            quote!(Some([ #( #b ),* ]))
        }
        None => quote!(None),
    }
}

fn limits(v: &ModrobVariable) -> String {
    let bound = |x: f64| {
        if x.is_infinite() {
            String::new()
        } else {
            x.to_string()
        }
    };
    match (v.min.is_infinite(), v.max.is_infinite()) {
        (true, true) => "no limits".to_string(),
        _ => format!("limits {}..={}", bound(v.min), bound(v.max)),
    }
}

/// The doc line of a variable: its description, then unit, direction, limits, rate.
fn variable_doc(v: &ModrobVariable, element: Option<u8>) -> String {
    let direction = match v.direction {
        Direction::Input => "input",
        Direction::Output => "output",
    };
    let mut text = v.description.clone();
    if let Some(i) = element {
        text = format!("Element {i} of `{}`. {text}", v.name.wire);
    }
    let rate = if v.rate > 0.0 {
        format!(", published at {} Hz", v.rate)
    } else {
        String::new()
    };
    let persist = if v.persist { ", persistent" } else { "" };
    format!(
        "{}\n\nUnit `{}`, {direction}, {}, default {}{rate}{persist}.",
        text.trim(),
        v.unit,
        limits(v),
        v.default
    )
}

fn emit_module(m: &ModrobModule) -> TokenStream {
    let file = file_name(&m.path);
    let mut text = format!(
        "ModRob-1 module dictionary `{file}`: `{}`, kind `{}`, MI {:#06x} by default.",
        m.dictionary, m.kind, m.module_id
    );
    if !m.description.is_empty() {
        text = format!("{}\n\n{text}", m.description);
    }
    let doc = inner(docs(&text));
    let count = lit(m.vi_count());
    let mut sorted: Vec<&ModrobVariable> = m.variables.iter().collect();
    sorted.sort_by_key(|v| v.vi);
    let mut entries = Vec::new();
    let mut variants = Vec::new();
    let mut from_vi = Vec::new();
    let mut fields = Vec::new();
    let mut defaults = Vec::new();
    let mut reads = Vec::new();
    let mut writes = Vec::new();
    let mut index = 0usize;
    for v in &sorted {
        let direction = match v.direction {
            Direction::Input => quote!(Input),
            Direction::Output => quote!(Output),
        };
        let (unit, min, max, default) = (&v.unit, float(v.min), float(v.max), float(v.default));
        let (persist, rate, description) = (v.persist, float(v.rate), &v.description);
        for i in 0..v.count {
            let vi = v.vi + i;
            let (name, variant, element) = if v.count > 1 {
                (
                    format!("{}[{i}]", v.name.wire),
                    format!("{}_{i}", v.name.rust),
                    Some(i),
                )
            } else {
                (v.name.wire.clone(), v.name.rust.clone(), None)
            };
            let vi_lit = Literal::u8_unsuffixed(vi);
            entries.push(quote! {
                ::ferrolink_runtime::modrob::Variable {
                    vi: #vi_lit,
                    name: #name,
                    unit: #unit,
                    direction: ::ferrolink_runtime::modrob::Direction::#direction,
                    min: #min,
                    max: #max,
                    default: #default,
                    persist: #persist,
                    rate: #rate,
                    description: #description,
                }
            });
            let variant = ident(&variant);
            let vdoc = docs(&variable_doc(v, element));
            variants.push(quote!(#vdoc #variant = #vi_lit,));
            from_vi.push(quote!(#vi_lit => Some(Var::#variant),));
        }
        let field = ident(&crate::ident::value_name(&v.name.wire));
        let fdoc = docs(&variable_doc(v, None));
        let at = lit(index);
        if v.count > 1 {
            let n = lit(usize::from(v.count));
            let end = lit(index + usize::from(v.count));
            fields.push(quote!(#fdoc pub #field: [f32; #n],));
            defaults.push(quote!(#field: [#default; #n],));
            reads.push(quote!(vars.#field.copy_from_slice(&values[#at..#end]);));
            writes.push(quote!(values[#at..#end].copy_from_slice(&self.#field);));
        } else {
            fields.push(quote!(#fdoc pub #field: f32,));
            defaults.push(quote!(#field: #default,));
            reads.push(quote!(vars.#field = values[#at];));
            writes.push(quote!(values[#at] = self.#field;));
        }
        index += usize::from(v.count);
    }
    let (name, kind, info) = (&m.dictionary, &m.kind, &m.info);
    let mi = hex(m.module_id.into(), 4);
    let fingerprint = hex(m.fingerprint, 8);
    let uuid = uuid(&m.uuid);
    let var_enum = if variants.is_empty() {
        quote!()
    } else {
        quote! {
            /// The variables, each with its VI as discriminant (`Var::X as u8`).
            #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
            #[allow(non_camel_case_types)]
            #[repr(u8)]
            pub enum Var {
                #( #variants )*
            }

            impl Var {
                /// Its VI.
                pub const fn vi(self) -> u8 {
                    self as u8
                }

                /// The variable with VI `vi`.
                pub const fn from_vi(vi: u8) -> Option<Var> {
                    match vi {
                        #( #from_vi )*
                        _ => None,
                    }
                }
            }
        }
    };
    let values_param = if reads.is_empty() {
        quote!(_values)
    } else {
        quote!(values)
    };
    let vars_mut = if reads.is_empty() {
        quote!()
    } else {
        quote!(mut)
    };
    quote! {
        #doc

        /// How many VIs the module has.
        pub const VARIABLES: usize = #count;

        /// The MI a module of this kind uses unless it is given another.
        pub const MODULE: u16 = #mi;

        /// Text for a person about the module, sent in piecewise chunks.
        pub const INFO: &str = #info;

        /// The variable table, one entry per VI, sorted by VI.
        pub const DICTIONARY: ::ferrolink_runtime::modrob::Dictionary<VARIABLES> =
            ::ferrolink_runtime::modrob::Dictionary {
                name: #name,
                kind: #kind,
                module: MODULE,
                uuid: #uuid,
                info: INFO,
                fingerprint: #fingerprint,
                variables: [ #( #entries ),* ],
            };

        /// The module engine over this dictionary.
        pub type Engine = ::ferrolink_runtime::modrob::engine::Engine<'static, VARIABLES>;

        /// A module engine at its defaults, with MI [`MODULE`].
        pub fn engine() -> Engine {
            Engine::new(&DICTIONARY)
        }

        #var_enum

        /// Every variable by name, with its type: `f32`, or `[f32; N]` for an array.
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct Vars {
            #( #fields )*
        }

        impl Vars {
            /// The defaults.
            pub const DEFAULT: Vars = Vars { #( #defaults )* };

            /// The variables from the engine's value array ([`Engine::values`]).
            pub fn from_values(#values_param: &[f32; VARIABLES]) -> Vars {
                let #vars_mut vars = Vars::DEFAULT;
                #( #reads )*
                vars
            }

            /// The variables as the engine's value array, in table order.
            pub fn to_values(&self) -> [f32; VARIABLES] {
                let #vars_mut values = [0.0; VARIABLES];
                #( #writes )*
                values
            }
        }

        impl Default for Vars {
            fn default() -> Self {
                Vars::DEFAULT
            }
        }
    }
}

fn emit_robot(ir: &Ir, robot: &Robot) -> TokenStream {
    let file = file_name(&robot.path);
    let leader = &robot.instances[robot.leader];
    let mut text = format!(
        "ModRob-1 robot `{file}`: {} modules on {} networks, led by `{}`.",
        robot.instances.len(),
        robot.networks.len(),
        leader.name.wire
    );
    if !robot.description.is_empty() {
        text = format!("{}\n\n{text}", robot.description);
    }
    let doc = inner(docs(&text));
    let networks = robot.networks.iter().map(|n| {
        let name = &n.name.wire;
        let transport = ident(match n.transport {
            Transport::Can => "Can",
            Transport::Uart => "Uart",
            Transport::Spi => "Spi",
            Transport::Ethernet => "Ethernet",
        });
        let bitrate = Literal::u32_unsuffixed(n.bitrate);
        quote! {
            ::ferrolink_runtime::modrob::Network {
                name: #name,
                transport: ::ferrolink_runtime::modrob::Transport::#transport,
                bitrate: #bitrate,
            }
        }
    });
    let mi_of = |i: usize| ident(&robot.instances[i].name.rust);
    let command = |mi: TokenStream, vi: u8, kind: TokenStream| {
        let vi = Literal::u8_unsuffixed(vi);
        quote! {
            ::ferrolink_runtime::modrob::Message::Command {
                module: #mi,
                variable: #vi,
                command: ::ferrolink_runtime::modrob::CommandKind::#kind,
            }
        }
    };
    let settings = |list: &[Setting], i: usize, kind: &str| -> Vec<TokenStream> {
        let kind = ident(kind);
        list.iter()
            .filter(|s| s.target.instance == i)
            .map(|s| {
                let (value, mi) = (float(s.value), mi_of(i));
                command(quote!(#mi), s.target.vi, quote!(#kind(#value)))
            })
            .collect()
    };
    let mut consts = Vec::new();
    let mut instances = Vec::new();
    for (i, inst) in robot.instances.iter().enumerate() {
        let dictionary = &ir.modrob[inst.dictionary];
        let network = &robot.networks[inst.network];
        let konst = ident(&inst.name.rust);
        let mi = hex(inst.module_id.into(), 4);
        let cdoc = docs(&format!(
            "MI of `{}` (dictionary `{}`, network `{}`).",
            inst.name.wire, dictionary.dictionary, network.name.wire
        ));
        consts.push(quote!(#cdoc pub const #konst: u16 = #mi;));
        let mut commands = settings(&robot.values, i, "SetValue");
        commands.extend(settings(&robot.rates, i, "SetFrequency"));
        for sub in robot
            .subscriptions
            .iter()
            .filter(|s| s.target.instance == i)
        {
            let source = mi_of(sub.source.instance);
            let vi = Literal::u8_unsuffixed(sub.source.vi);
            commands.push(command(
                quote!(#konst),
                sub.target.vi,
                quote!(SetSubscription { module: #source, variable: #vi }),
            ));
        }
        let (name, dict) = (&inst.name.wire, &dictionary.dictionary);
        let uuid = uuid(&inst.uuid);
        let network = lit(inst.network);
        instances.push(quote! {
            ::ferrolink_runtime::modrob::Instance {
                name: #name,
                dictionary: #dict,
                module: #konst,
                uuid: #uuid,
                network: #network,
                commands: &[ #( #commands ),* ],
            }
        });
    }
    let (name, n_networks, n_instances) = (
        &robot.name.wire,
        lit(robot.networks.len()),
        lit(robot.instances.len()),
    );
    let leader = lit(robot.leader);
    quote! {
        #doc

        #( #consts )*

        /// The robot's networks.
        pub const NETWORKS: [::ferrolink_runtime::modrob::Network; #n_networks] = [ #( #networks ),* ];

        /// The robot's modules, each with the commands the leader sends when it appears: stored
        /// values, then publication rates, then subscriptions.
        pub const INSTANCES: [::ferrolink_runtime::modrob::Instance; #n_instances] = [ #( #instances ),* ];

        /// The robot, for the leader engine.
        pub const ROBOT: ::ferrolink_runtime::modrob::Robot = ::ferrolink_runtime::modrob::Robot {
            name: #name,
            networks: &NETWORKS,
            instances: &INSTANCES,
            leader: #leader,
        };
    }
}
