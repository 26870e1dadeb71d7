//! Wireshark dissectors in Lua for a run's dictionaries: MAVLink and NDLCom (from the MAVLink
//! XML files), ModRob-1 (from module dictionaries and robots) and TosNet (from register maps),
//! rendered from `tools/templates/wireshark/`.

use minijinja::context;

use crate::ir::Ir;

/// One Lua file with a dissector for every protocol `ir` describes.
pub fn generate(ir: &Ir) -> Result<String, minijinja::Error> {
    let env = super::jinja::environment();
    let template = env.get_template("wireshark/dissectors.lua.j2")?;
    template
        .render(context! { ir => super::jinja::ir_value(ir), version => env!("CARGO_PKG_VERSION") })
}
