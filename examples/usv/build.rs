fn main() {
    ferrolink_codegen::Config::new()
        .input("../../definitions/mavlink/usv.xml")
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
}
