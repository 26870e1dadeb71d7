//! The vehicle's 64 parameters: names, types and defaults in a table in flash, the values in
//! RAM.
//!
//! The names are PX4's where PX4 has the parameter (its types are INT32 and REAL32 only); the
//! others are named in its style. Every type PARAM_VALUE carries is there: 8 UINT8, 6 INT8,
//! 8 UINT16, 6 INT16, 6 UINT32, 10 INT32 and 20 REAL32.
//!
//! `SYS_STACK_USED` is read-only: the most stack the firmware has used since start-up, in
//! bytes, updated once a second. A set of it is refused (answered with the value it holds).

use ferrolink_runtime::mavlink::service::param::{Name, Param, Store, Value};
use ferrolink_runtime::mavlink::CharArray;

/// How many parameters there are.
pub const COUNT: usize = 64;

/// A parameter name from text (up to 16 bytes, the rest NUL) at compile time.
const fn name(text: &str) -> Name {
    let bytes = text.as_bytes();
    assert!(bytes.len() <= 16, "a parameter name has at most 16 bytes");
    let mut out = [0u8; 16];
    let mut i = 0;
    while i < bytes.len() {
        out[i] = bytes[i];
        i += 1;
    }
    CharArray(out)
}

const fn p(text: &str, value: Value) -> Entry {
    Entry {
        name: name(text),
        default: Narrow::from_value(value),
    }
}

/// A [`Value`] of 32 bits or fewer, in 8 bytes (a `Value`, which can hold 64 bits, takes 16).
#[derive(Debug, Clone, Copy)]
enum Narrow {
    U8(u8),
    I8(i8),
    U16(u16),
    I16(i16),
    U32(u32),
    I32(i32),
    F32(f32),
}

impl Narrow {
    /// `v`, or `None` for the 64-bit types, which no parameter here has.
    const fn new(v: Value) -> Option<Self> {
        Some(match v {
            Value::U8(v) => Narrow::U8(v),
            Value::I8(v) => Narrow::I8(v),
            Value::U16(v) => Narrow::U16(v),
            Value::I16(v) => Narrow::I16(v),
            Value::U32(v) => Narrow::U32(v),
            Value::I32(v) => Narrow::I32(v),
            Value::F32(v) => Narrow::F32(v),
            Value::U64(_) | Value::I64(_) | Value::F64(_) => return None,
        })
    }

    /// `v`, at compile time.
    const fn from_value(v: Value) -> Self {
        match Narrow::new(v) {
            Some(n) => n,
            None => panic!("no parameter here has a 64-bit type"),
        }
    }

    const fn value(self) -> Value {
        match self {
            Narrow::U8(v) => Value::U8(v),
            Narrow::I8(v) => Value::I8(v),
            Narrow::U16(v) => Value::U16(v),
            Narrow::I16(v) => Value::I16(v),
            Narrow::U32(v) => Value::U32(v),
            Narrow::I32(v) => Value::I32(v),
            Narrow::F32(v) => Value::F32(v),
        }
    }
}

/// A parameter in [`TABLE`]: its name and default.
#[derive(Debug, Clone, Copy)]
pub struct Entry {
    /// The name.
    pub name: Name,
    default: Narrow,
}

impl Entry {
    /// The default, whose type is the parameter's.
    pub const fn default(&self) -> Value {
        self.default.value()
    }
}

/// Where [`TABLE`] has `SYS_STACK_USED`.
pub const STACK_USED: u16 = 33;

/// Every parameter with its default, in index order.
pub static TABLE: [Entry; COUNT] = [
    // UINT8
    p("MAV_PROTO_VER", Value::U8(2)),
    p("BAT1_N_CELLS", Value::U8(4)),
    p("COM_RC_IN_MODE", Value::U8(0)),
    // Data link loss action: 0 none, any other disarms (see `vehicle`).
    p("NAV_DLL_ACT", Value::U8(0)),
    p("NAV_RCL_ACT", Value::U8(2)),
    p("MOT_ORDERING", Value::U8(0)),
    p("CA_ROTOR_COUNT", Value::U8(4)),
    p("SENS_BOARD_ROT", Value::U8(0)),
    // INT8
    p("CAL_MAG0_ROT", Value::I8(-1)),
    p("CAL_MAG1_ROT", Value::I8(-1)),
    p("IMU_TEMP_OFF", Value::I8(-3)),
    p("PWM_TRIM_ROLL", Value::I8(-5)),
    p("PWM_TRIM_PITCH", Value::I8(3)),
    p("PWM_TRIM_YAW", Value::I8(0)),
    // UINT16
    p("PWM_MAIN_MIN", Value::U16(1000)),
    p("PWM_MAIN_MAX", Value::U16(2000)),
    p("PWM_MAIN_DISARM", Value::U16(900)),
    p("PWM_MAIN_RATE", Value::U16(400)),
    p("RC1_MIN", Value::U16(1000)),
    p("RC1_MAX", Value::U16(2000)),
    p("RC1_TRIM", Value::U16(1500)),
    p("BAT1_CAPACITY", Value::U16(5000)),
    // INT16
    p("PWM_MAIN_TRIM1", Value::I16(-20)),
    p("PWM_MAIN_TRIM2", Value::I16(15)),
    p("PWM_MAIN_TRIM3", Value::I16(0)),
    p("PWM_MAIN_TRIM4", Value::I16(-8)),
    p("CAL_BARO_OFFS", Value::I16(-120)),
    p("EKF2_MAG_DELAY", Value::I16(0)),
    // UINT32
    p("SER_TEL1_BAUD", Value::U32(921_600)),
    p("SER_GPS1_BAUD", Value::U32(115_200)),
    p("CAL_ACC0_ID", Value::U32(1_310_988)),
    p("CAL_GYRO0_ID", Value::U32(1_310_988)),
    p("CAL_MAG0_ID", Value::U32(396_825)),
    // Read-only: index `STACK_USED`.
    p("SYS_STACK_USED", Value::U32(0)),
    // INT32
    p("SYS_AUTOSTART", Value::I32(4001)),
    p("SYS_AUTOCONFIG", Value::I32(0)),
    p("COM_ARM_WO_GPS", Value::I32(1)),
    p("COM_FLTMODE1", Value::I32(0)),
    p("COM_FLTMODE2", Value::I32(2)),
    p("MAV_0_RATE", Value::I32(1200)),
    p("CBRK_IO_SAFETY", Value::I32(22_027)),
    p("CBRK_SUPPLY_CHK", Value::I32(0)),
    p("GF_ACTION", Value::I32(1)),
    p("EKF2_AID_MASK", Value::I32(1)),
    // REAL32
    p("MPC_XY_VEL_MAX", Value::F32(12.0)),
    p("MPC_Z_VEL_MAX_UP", Value::F32(3.0)),
    p("MPC_Z_VEL_MAX_DN", Value::F32(1.5)),
    p("MPC_TILTMAX_AIR", Value::F32(45.0)),
    p("MPC_THR_HOVER", Value::F32(0.5)),
    p("MC_ROLL_P", Value::F32(6.5)),
    p("MC_PITCH_P", Value::F32(6.5)),
    p("MC_YAW_P", Value::F32(2.8)),
    p("MC_ROLLRATE_P", Value::F32(0.15)),
    p("MC_PITCHRATE_P", Value::F32(0.15)),
    p("MC_YAWRATE_P", Value::F32(0.2)),
    p("MIS_TAKEOFF_ALT", Value::F32(2.5)),
    p("RTL_RETURN_ALT", Value::F32(60.0)),
    p("GF_MAX_HOR_DIST", Value::F32(500.0)),
    p("GF_MAX_VER_DIST", Value::F32(120.0)),
    p("BAT1_V_EMPTY", Value::F32(3.5)),
    p("BAT1_V_CHARGED", Value::F32(4.05)),
    p("COM_DISARM_LAND", Value::F32(2.0)),
    p("LNDMC_Z_VEL_MAX", Value::F32(0.5)),
    p("EKF2_BARO_NOISE", Value::F32(3.5)),
];

/// The index of `NAV_DLL_ACT`.
pub const NAV_DLL_ACT: u16 = 3;

/// Whether two names are equal (`==` is not available in a `const fn`).
const fn same_bytes(a: &[u8; 16], b: &[u8; 16]) -> bool {
    let mut i = 0;
    while i < 16 {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// Whether every name in [`TABLE`] is different.
const fn names_unique() -> bool {
    let mut i = 0;
    while i < COUNT {
        let mut j = i + 1;
        while j < COUNT {
            if same_bytes(&TABLE[i].name.0, &TABLE[j].name.0) {
                return false;
            }
            j += 1;
        }
        i += 1;
    }
    true
}

// Checked at compile time: the names are unique, and the indices the firmware uses are where
// it thinks they are.
const _: () = assert!(names_unique(), "two parameters have the same name");
const _: () = assert!(same_bytes(
    &TABLE[STACK_USED as usize].name.0,
    &name("SYS_STACK_USED").0
));
const _: () = assert!(same_bytes(
    &TABLE[NAV_DLL_ACT as usize].name.0,
    &name("NAV_DLL_ACT").0
));

/// The parameters' values, in RAM; names and types are [`TABLE`]'s.
#[derive(Debug)]
pub struct Params {
    values: [Narrow; COUNT],
}

impl Params {
    /// Every parameter at its default.
    pub const fn new() -> Self {
        let mut values = [Narrow::U8(0); COUNT];
        let mut i = 0;
        while i < COUNT {
            values[i] = TABLE[i].default;
            i += 1;
        }
        Self { values }
    }

    /// The value of parameter `index`, if there is one.
    pub fn value(&self, index: u16) -> Option<Value> {
        self.values.get(usize::from(index)).map(|v| v.value())
    }

    /// Sets a read-only parameter, which [`Store::set`] refuses.
    pub fn update(&mut self, index: u16, value: Value) {
        if let (Some(v), Some(new)) = (self.values.get_mut(usize::from(index)), Narrow::new(value))
        {
            *v = new;
        }
    }
}

impl Store for Params {
    // PARAM_* only, every type of 32 bits or fewer.
    const EXTENDED: bool = false;

    fn count(&self) -> u16 {
        COUNT as u16
    }

    fn get(&self, index: u16) -> Option<Param> {
        let name = TABLE.get(usize::from(index))?.name;
        let value = self.value(index)?;
        Some(Param { name, value })
    }

    fn index_of(&self, name: &Name) -> Option<u16> {
        TABLE.iter().position(|p| p.name == *name).map(|i| i as u16)
    }

    fn set(&mut self, index: u16, value: Value) -> Option<Value> {
        if index == STACK_USED {
            return None;
        }
        let v = self.values.get_mut(usize::from(index))?;
        *v = Narrow::new(value)?;
        Some(value)
    }
}
