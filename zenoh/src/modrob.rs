//! A ModRob-1 leader's upstream port on Zenoh.
//!
//! - **Up.** What the leader sends upstream is put under `<prefix>/modrob/<robot>`:
//!   publications on `<instance>/<variable>`, commands on `<instance>/<variable>/command`,
//!   piecewise chunks on `<instance>/piecewise` (an instance or variable the robot file does not
//!   name appears as `mi<MI>` or `vi<VI>`). A sample is the message in UART.B-1 form (`raw`) or
//!   in the JSON form of `ferrolink modrob decode` (`json`):
//!   `{"type":"publication","module":258,"variable":3,"value":1.5}`.
//! - **Down.** A number put on `<prefix>/modrob/<robot>/<instance>/<variable>/set` is a
//!   `set_value` command to that variable; a whole message put on `<prefix>/modrob/<robot>/tx`,
//!   as UART.B-1 bytes (first byte 0x5A) or JSON, is taken as it is. Both arrive at the leader as
//!   if from its upstream port. The port's own puts never come back.

use std::io;

use ferrolink_io::modrob::json;
use ferrolink_runtime::modrob::dictionary::Robot;
use ferrolink_runtime::modrob::{uart, CommandKind, Message};
use zenoh::handlers::FifoChannelHandler;
use zenoh::pubsub::Subscriber;
use zenoh::sample::Sample;
use zenoh::Wait;

use crate::session::{Rejections, Running};
use crate::uri::{Encoding, ZenohUri};

/// Names a dictionary's variable: `(dictionary name, VI) -> variable name`.
pub type VariableName = fn(&str, u8) -> Option<&'static str>;

/// What the port counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// Messages put on Zenoh.
    pub published: u64,
    /// Messages taken from Zenoh.
    pub received: u64,
    /// Samples that carried no message (reported on stderr).
    pub rejected: u64,
}

/// The upstream port.
#[derive(Debug)]
pub struct Upstream {
    running: Running,
    root: String,
    encoding: Encoding,
    robot: &'static Robot,
    variable_name: VariableName,
    down: Subscriber<FifoChannelHandler<Sample>>,
    rejected: Rejections,
    stats: Stats,
}

impl Upstream {
    /// Joins the Zenoh network `uri` names for `robot`, whose variables `variable_name` names.
    pub fn open(
        uri: &ZenohUri,
        robot: &'static Robot,
        variable_name: VariableName,
    ) -> io::Result<Self> {
        let running = Running::open(uri)?;
        let root = format!("{}/modrob/{}", uri.prefix, robot.name);
        let down = running.subscribe_remote(format!("{root}/**"))?;
        Ok(Self {
            running,
            root,
            encoding: uri.encoding,
            robot,
            variable_name,
            down,
            rejected: Rejections::default(),
            stats: Stats::default(),
        })
    }

    /// The counters.
    pub fn stats(&self) -> Stats {
        self.stats
    }

    fn instance(&self, module: u16) -> String {
        self.robot
            .instance(module)
            .map_or_else(|| format!("mi{module}"), |i| i.name.to_owned())
    }

    fn variable(&self, module: u16, vi: u8) -> String {
        self.robot
            .instance(module)
            .and_then(|i| (self.variable_name)(i.dictionary, vi))
            .map_or_else(|| format!("vi{vi}"), str::to_owned)
    }

    /// The key `message` is put on.
    pub fn key(&self, message: &Message) -> String {
        match *message {
            Message::Publication {
                module, variable, ..
            } => format!(
                "{}/{}/{}",
                self.root,
                self.instance(module),
                self.variable(module, variable)
            ),
            Message::Command {
                module, variable, ..
            } => format!(
                "{}/{}/{}/command",
                self.root,
                self.instance(module),
                self.variable(module, variable)
            ),
            Message::Piecewise { module, .. } => {
                format!("{}/{}/piecewise", self.root, self.instance(module))
            }
        }
    }

    /// Puts `message` on its key.
    pub fn publish(&mut self, message: &Message) -> io::Result<()> {
        let key = self.key(message);
        let put = match self.encoding {
            Encoding::Raw => {
                let mut out = [0u8; 16];
                let n = uart::encode(message, &mut out)
                    .map_err(|e| io::Error::other(format!("{e:?}")))?;
                self.running.session().put(key, out[..n].to_vec()).wait()
            }
            Encoding::Json => self
                .running
                .session()
                .put(key, json::to_string(message))
                .wait(),
        };
        put.map_err(|e| io::Error::other(e.to_string()))?;
        self.stats.published += 1;
        Ok(())
    }

    /// Hands every message that came down to `on_message`, without blocking; returns how many.
    pub fn receive(&mut self, mut on_message: impl FnMut(Message)) -> usize {
        let mut n = 0;
        while let Ok(Some(sample)) = self.down.try_recv() {
            let key = sample.key_expr().as_str().to_owned();
            let bytes = sample.payload().to_bytes();
            match self.message(&key, &bytes) {
                Ok(Some(message)) => {
                    self.stats.received += 1;
                    n += 1;
                    on_message(message);
                }
                // Another port's puts (publications of a second robot process, say).
                Ok(None) => {}
                Err(e) => {
                    self.stats.rejected += 1;
                    self.rejected.note(&key, &e);
                }
            }
        }
        n
    }

    /// The message a sample on `key` carries: `None` for keys that carry none downwards.
    fn message(&self, key: &str, bytes: &[u8]) -> Result<Option<Message>, String> {
        let rest = key.strip_prefix(&self.root).unwrap_or(key);
        let parts: Vec<&str> = rest.trim_start_matches('/').split('/').collect();
        match parts[..] {
            ["tx"] => {
                if bytes.first() == Some(&uart::SYNC) {
                    uart::decode(bytes).map(Some).map_err(|e| format!("{e:?}"))
                } else {
                    let text = std::str::from_utf8(bytes).map_err(|e| e.to_string())?;
                    json::from_str(text).map(Some)
                }
            }
            [instance, variable, "set"] => {
                let inst = self
                    .robot
                    .instances
                    .iter()
                    .find(|i| i.name == instance)
                    .ok_or_else(|| format!("the robot has no instance {instance}"))?;
                let vi = (0..=u8::MAX)
                    .find(|&vi| (self.variable_name)(inst.dictionary, vi) == Some(variable))
                    .ok_or_else(|| format!("{instance} has no variable {variable}"))?;
                let text = std::str::from_utf8(bytes).map_err(|e| e.to_string())?;
                let value: f32 = text
                    .trim()
                    .parse()
                    .map_err(|e| format!("a set value is a number: {e}"))?;
                Ok(Some(Message::Command {
                    module: inst.module,
                    variable: vi,
                    command: CommandKind::SetValue(value),
                }))
            }
            _ => Ok(None),
        }
    }
}
