//! ModRob-1 messages as JSON, the form `ferrolink modrob encode` reads and `decode` prints and
//! the Zenoh upstream of a leader publishes: one object per message, e.g.
//! `{"type":"publication","module":258,"variable":3,"value":1.5}`,
//! `{"type":"command","command":"set_value","module":258,"variable":3,"value":0.5}`,
//! `{"type":"piecewise","module":258,"chunk":0,"chunks":2,"data":"<hex>"}`.

use ferrolink_runtime::modrob::{CommandKind, Message};
use serde::{Deserialize, Serialize};

/// A message as one line of JSON.
pub fn to_string(message: &Message) -> String {
    serde_json::to_string(&MessageJson::from_message(message)).unwrap_or_default()
}

/// A message from JSON; errors say what is wrong.
pub fn from_str(text: &str) -> Result<Message, String> {
    serde_json::from_str::<MessageJson>(text)
        .map_err(|e| e.to_string())
        .and_then(|m| m.to_message())
}

/// A float32 in JSON: a number, or `"NaN"`, `"inf"`, `"-inf"`, which JSON numbers cannot be.
#[derive(Serialize, Deserialize)]
#[serde(untagged)]
enum Value {
    Number(f32),
    Special(String),
}

impl Value {
    fn from_f32(v: f32) -> Self {
        if v.is_finite() {
            Value::Number(v)
        } else if v.is_nan() {
            Value::Special("NaN".into())
        } else if v > 0.0 {
            Value::Special("inf".into())
        } else {
            Value::Special("-inf".into())
        }
    }

    fn to_f32(&self) -> Result<f32, String> {
        match self {
            Value::Number(v) => Ok(*v),
            Value::Special(s) => match s.as_str() {
                "NaN" => Ok(f32::NAN),
                "inf" => Ok(f32::INFINITY),
                "-inf" => Ok(f32::NEG_INFINITY),
                _ => Err(format!(
                    "value `{s}` is neither a number nor NaN, inf or -inf"
                )),
            },
        }
    }
}

#[derive(Clone, Copy, Serialize, Deserialize)]
enum CommandName {
    #[serde(rename = "set_value")]
    Value,
    #[serde(rename = "set_frequency")]
    Frequency,
    #[serde(rename = "set_subscription")]
    Subscription,
}

/// One message in the JSON form of `encode` and `decode`.
#[derive(Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
enum MessageJson {
    Command {
        command: CommandName,
        module: u16,
        variable: u8,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        value: Option<Value>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        source_module: Option<u16>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        source_variable: Option<u8>,
    },
    Publication {
        module: u16,
        variable: u8,
        value: Value,
    },
    Piecewise {
        module: u16,
        chunk: u8,
        chunks: u8,
        data: String,
    },
}

impl MessageJson {
    fn from_message(message: &Message) -> Self {
        match *message {
            Message::Command {
                module,
                variable,
                command,
            } => {
                let (command, value, source) = match command {
                    CommandKind::SetValue(v) => (CommandName::Value, Some(v), None),
                    CommandKind::SetFrequency(v) => (CommandName::Frequency, Some(v), None),
                    CommandKind::SetSubscription { module, variable } => {
                        (CommandName::Subscription, None, Some((module, variable)))
                    }
                };
                MessageJson::Command {
                    command,
                    module,
                    variable,
                    value: value.map(Value::from_f32),
                    source_module: source.map(|s| s.0),
                    source_variable: source.map(|s| s.1),
                }
            }
            Message::Publication {
                module,
                variable,
                value,
            } => MessageJson::Publication {
                module,
                variable,
                value: Value::from_f32(value),
            },
            Message::Piecewise {
                module,
                chunk,
                chunks,
                data,
            } => MessageJson::Piecewise {
                module,
                chunk,
                chunks,
                data: hex::encode(data),
            },
        }
    }

    fn to_message(&self) -> Result<Message, String> {
        Ok(match self {
            MessageJson::Command {
                command,
                module,
                variable,
                value,
                source_module,
                source_variable,
            } => {
                let command = match (command, value, source_module, source_variable) {
                    (CommandName::Value, Some(v), None, None) => {
                        CommandKind::SetValue(v.to_f32()?)
                    }
                    (CommandName::Frequency, Some(v), None, None) => {
                        CommandKind::SetFrequency(v.to_f32()?)
                    }
                    (CommandName::Value | CommandName::Frequency, ..) => {
                        return Err(
                            "set_value and set_frequency take `value` and no `source_module` or `source_variable`"
                                .into(),
                        )
                    }
                    (CommandName::Subscription, None, Some(m), Some(v)) => {
                        CommandKind::SetSubscription {
                            module: *m,
                            variable: *v,
                        }
                    }
                    (CommandName::Subscription, ..) => {
                        return Err(
                            "set_subscription takes `source_module` and `source_variable` and no `value`"
                                .into(),
                        )
                    }
                };
                Message::Command {
                    module: *module,
                    variable: *variable,
                    command,
                }
            }
            MessageJson::Publication {
                module,
                variable,
                value,
            } => Message::Publication {
                module: *module,
                variable: *variable,
                value: value.to_f32()?,
            },
            MessageJson::Piecewise {
                module,
                chunk,
                chunks,
                data,
            } => {
                let bytes =
                    hex::decode(data.trim()).map_err(|e| format!("data is not hex: {e}"))?;
                let mut chunk_data = [0u8; 7];
                chunk_data
                    .get_mut(..bytes.len())
                    .ok_or_else(|| format!("data of {} bytes exceeds a chunk's 7", bytes.len()))?
                    .copy_from_slice(&bytes);
                Message::Piecewise {
                    module: *module,
                    chunk: *chunk,
                    chunks: *chunks,
                    data: chunk_data,
                }
            }
        })
    }
}
