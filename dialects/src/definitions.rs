//! The standard dialects' wire-facts files, as text, for decoding at run time: the CLI's
//! `--dialect NAME` loads them through [`ferrolink_dictionary::load_with`] from here. They are
//! `definitions/mavlink/standard/`, built in; no generated code is needed to use them.
//!
//! ```
//! let ardupilotmega = ferrolink_dialects::definitions::find("ArduPilotMega").unwrap();
//! assert_eq!(ardupilotmega.file, "ardupilotmega.xml");
//! assert!(ardupilotmega.text.contains("<include>common.xml</include>"));
//! ```
//!
//! [`ferrolink_dictionary::load_with`]: https://docs.rs/ferrolink-dictionary

/// One dialect file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Definition {
    /// The dialect's name, its file stem: `ardupilotmega`, `ASLUAV`.
    pub name: &'static str,
    /// The file name, as includes name it: `ardupilotmega.xml`.
    pub file: &'static str,
    /// The XML.
    pub text: &'static str,
}

macro_rules! def {
    ($name:literal) => {
        Definition {
            name: $name,
            file: concat!($name, ".xml"),
            text: include_str!(concat!(
                "../../definitions/mavlink/standard/",
                $name,
                ".xml"
            )),
        }
    };
}

/// Every standard dialect, by name (case-insensitive order).
pub const ALL: &[Definition] = &[
    def!("all"),
    def!("ardupilotmega"),
    def!("ASLUAV"),
    def!("AVSSUAS"),
    def!("common"),
    def!("csAirLink"),
    def!("cubepilot"),
    def!("development"),
    def!("icarous"),
    def!("loweheiser"),
    def!("matrixpilot"),
    def!("minimal"),
    def!("paparazzi"),
    def!("python_array_test"),
    def!("standard"),
    def!("storm32"),
    def!("test"),
    def!("ualberta"),
    def!("uAvionix"),
];

/// The dialect called `name` (its file stem, any case; `.xml` may follow).
pub fn find(name: &str) -> Option<&'static Definition> {
    let name = name.strip_suffix(".xml").unwrap_or(name);
    ALL.iter().find(|d| d.name.eq_ignore_ascii_case(name))
}

/// The dialect in the file named `file` (an include's name, exact case).
pub fn by_file(file: &str) -> Option<&'static Definition> {
    ALL.iter().find(|d| d.file == file)
}
