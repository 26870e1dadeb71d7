//! What the generator emits for ModRob-1 dictionaries: a module's variable table and a robot's
//! stored configuration, as `const` data the engines read.
//!
//! A module dictionary becomes a [`Dictionary`]: its name, kind, default MI, optional UUID,
//! info text and one [`Variable`] per VI, sorted by VI. A robot file becomes a [`Robot`]: its
//! networks and module instances, each instance with the commands the leader sends it when it
//! appears.

use super::message::Message;

/// Whether setting a variable from outside changes the module's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Direction {
    /// Setting it changes the module's state (a set point, a mode).
    Input,
    /// The module produces it (a reading); a value set from outside changes no state and the
    /// module may overwrite it.
    Output,
}

/// One variable of a module: one VI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Variable {
    /// Its VI.
    pub vi: u8,
    /// Its name in the dictionary; an element of an array variable is `name[i]`.
    pub name: &'static str,
    /// Its SI unit (`m/s`, `rad`, `kA`, `1` for a plain number) or dimensionless kind (`mode`,
    /// `counter`, `ratio`).
    pub unit: &'static str,
    /// Input or output.
    pub direction: Direction,
    /// The smallest value accepted.
    pub min: f32,
    /// The largest value accepted.
    pub max: f32,
    /// The value at power-up (and when no valid stored image exists).
    pub default: f32,
    /// Whether its value is kept in non-volatile memory.
    pub persist: bool,
    /// The publication rate at power-up, in Hz; 0 publishes nothing.
    pub rate: f32,
    /// What it is.
    pub description: &'static str,
}

impl Variable {
    /// Whether `value` is within the limits (NaN never is).
    pub fn accepts(&self, value: f32) -> bool {
        value >= self.min && value <= self.max
    }
}

/// A module's dictionary: everything the generator knows about it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dictionary<const N: usize> {
    /// The module's name in the dictionary (`drive`).
    pub name: &'static str,
    /// What kind of module it is (`drive`, `distance_sensor`).
    pub kind: &'static str,
    /// The MI it uses unless told otherwise.
    pub module: u16,
    /// Its UUID on Ethernet-1, if the dictionary gives one.
    pub uuid: Option<[u8; 16]>,
    /// Text for a person, sent in piecewise chunks.
    pub info: &'static str,
    /// A hash of the variable table (VIs, names, units, directions, limits, persist flags),
    /// computed by the generator; a stored image made for another table is refused.
    pub fingerprint: u32,
    /// The variables, sorted by VI.
    pub variables: [Variable; N],
}

impl<const N: usize> Dictionary<N> {
    /// The position of `vi` in [`Dictionary::variables`].
    pub fn index_of(&self, vi: u8) -> Option<usize> {
        self.variables.binary_search_by_key(&vi, |v| v.vi).ok()
    }

    /// The variable with VI `vi`.
    pub fn variable(&self, vi: u8) -> Option<&Variable> {
        self.index_of(vi).map(|i| &self.variables[i])
    }
}

/// What carries a network of a robot, with its nominal rate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Transport {
    /// ModRob.CAN-1.
    Can,
    /// ModRob.UART.B-1.
    Uart,
    /// ModRob.SPI-1.
    Spi,
    /// ModRob.Ethernet-1.
    Ethernet,
}

/// One communication network of a robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Network {
    /// Its name in the robot file.
    pub name: &'static str,
    /// Its transport.
    pub transport: Transport,
    /// Its bit rate, in bit/s.
    pub bitrate: u32,
}

/// One module of a robot: which dictionary, at which address, on which network, and the stored
/// configuration the leader sends it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Instance {
    /// Its name in the robot file (`drive_fl`).
    pub name: &'static str,
    /// The name of its dictionary (`drive`).
    pub dictionary: &'static str,
    /// Its MI.
    pub module: u16,
    /// Its UUID on Ethernet-1, if any.
    pub uuid: Option<[u8; 16]>,
    /// The index of its network in [`Robot::networks`].
    pub network: usize,
    /// The commands the leader sends when the module appears: values, then publication rates,
    /// then subscriptions, in the robot file's order.
    pub commands: &'static [Message],
}

/// A robot (composite module): its networks, its modules and its leader.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Robot {
    /// Its name.
    pub name: &'static str,
    /// Its networks.
    pub networks: &'static [Network],
    /// Its modules, the leader among them.
    pub instances: &'static [Instance],
    /// The index of the leader in [`Robot::instances`].
    pub leader: usize,
}

impl Robot {
    /// The instance with MI `module`.
    pub fn instance(&self, module: u16) -> Option<&Instance> {
        self.instances.iter().find(|i| i.module == module)
    }
}
