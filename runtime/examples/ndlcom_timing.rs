//! Simulated NDLCom ping round trips over 1 to 6 bridges, cut-through and store & forward,
//! against the timing model, as a Markdown table.
//!
//! ```text
//! cargo run -p ferrolink-runtime --example ndlcom_timing
//! ```
//!
//! The simulation is the one `tests/ndlcom_sim.rs` checks: see `tests/sim/mod.rs` for how the
//! network is modelled and why the measured times come out below the model.

#[path = "../tests/sim/mod.rs"]
mod sim;

fn main() {
    let rows = sim::timing_rows(sim::TIMING_BAUD, sim::TIMING_PAYLOAD, 1..=6);
    print!(
        "{}",
        sim::timing_markdown(sim::TIMING_BAUD, sim::TIMING_PAYLOAD, &rows)
    );
}
