//! The MAVLink microservices' state machines, each side alone and both sides through a lossy
//! link.

mod command;
mod lossy;
mod param;
