//! `ferrolink modrob ...`: ModRob-1 messages to and from their CAN-1, UART.B-1, SPI-1 and
//! Ethernet-1 wire forms, for checking other implementations against ours.

use std::io::{self, BufRead, Write};
use std::process::ExitCode;

use clap::{Subcommand, ValueEnum};
use ferrolink_io::modrob::json;
use ferrolink_runtime::modrob::ethernet::{self, Packet, PacketBuilder};
use ferrolink_runtime::modrob::{parser::Parser, uart, Message};
use serde::Serialize;

use crate::ndlcom::HexReader;

#[derive(Subcommand)]
pub enum Command {
    /// Encode messages: reads JSON lines such as
    /// `{"type":"publication","module":258,"variable":3,"value":1.5}` from stdin and prints
    /// each message's wire form as hex (`<id> <data>` for CAN), or for Ethernet the packets.
    Encode {
        /// The wire form.
        #[arg(long, value_enum)]
        transport: Transport,
        /// Ethernet: the sending module's UUID.
        #[arg(
            long,
            value_name = "UUID",
            value_parser = parse_uuid,
            required_if_eq("transport", "ethernet")
        )]
        module_uuid: Option<[u8; 16]>,
        /// Ethernet: the first packet's message id (later packets count up from it); a new
        /// monotonic ULID if omitted.
        #[arg(long, value_name = "ULID", value_parser = parse_ulid)]
        message_ulid: Option<ulid::Ulid>,
        /// Ethernet: the largest datagram; messages that do not fit go into further packets.
        #[arg(long, value_name = "BYTES", default_value_t = ethernet::MAX_DATAGRAM_LEN)]
        max_datagram: usize,
    },
    /// Decode hex from stdin and print one JSON line per valid message. CAN: lines
    /// `<id> <data>`; UART/SPI: one stream (whitespace ignored, garbage allowed), then
    /// `{"frames":N,"crc_failures":N,"bad_length":N,"decode_errors":N,"dropped":M}`;
    /// Ethernet: one packet per line.
    Decode {
        /// The wire form.
        #[arg(long, value_enum)]
        transport: Transport,
    },
}

/// A ModRob-1 network.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Transport {
    /// CAN-1: a 29-bit identifier and 6 or 8 data bytes.
    Can,
    /// UART.B-1: `0x5A | id_and_len | data | crc8`.
    Uart,
    /// SPI-1: the same bytes as UART.B-1.
    Spi,
    /// Ethernet-1: ULID, module UUID, count, UART.B-1 messages.
    Ethernet,
}

fn parse_uuid(s: &str) -> Result<[u8; 16], String> {
    uuid::Uuid::parse_str(s)
        .map(|u| *u.as_bytes())
        .map_err(|e| e.to_string())
}

fn parse_ulid(s: &str) -> Result<ulid::Ulid, String> {
    ulid::Ulid::from_string(s).map_err(|e| e.to_string())
}

/// The summary line of a UART/SPI decode, in this order.
#[derive(Serialize)]
struct StatsJson {
    frames: u64,
    crc_failures: u64,
    bad_length: u64,
    decode_errors: u64,
    dropped: u64,
}

pub fn run(command: Command) -> Result<ExitCode, Box<dyn std::error::Error>> {
    match command {
        Command::Encode {
            transport,
            module_uuid,
            message_ulid,
            max_datagram,
        } => encode(transport, module_uuid, message_ulid, max_datagram),
        Command::Decode { transport } => match transport {
            Transport::Can => decode_can(),
            Transport::Uart | Transport::Spi => decode_stream(),
            Transport::Ethernet => decode_ethernet(),
        },
    }
}

fn exit_code(failed: bool) -> ExitCode {
    if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

fn print_message(out: &mut impl Write, message: &Message) -> io::Result<()> {
    writeln!(out, "{}", json::to_string(message))
}

fn encode(
    transport: Transport,
    module_uuid: Option<[u8; 16]>,
    message_ulid: Option<ulid::Ulid>,
    max_datagram: usize,
) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let stdout = io::stdout();
    let mut out = io::BufWriter::new(stdout.lock());
    let mut failed = false;
    let mut messages = Vec::new();
    for (n, line) in io::stdin().lock().lines().enumerate() {
        let line = line?;
        if line.trim().is_empty() {
            continue;
        }
        let message = json::from_str(&line);
        let message = match message {
            Ok(message) => message,
            Err(e) => {
                out.flush()?;
                eprintln!("stdin:{}: {e}", n + 1);
                failed = true;
                continue;
            }
        };
        match transport {
            Transport::Can => {
                let can = message.to_can();
                writeln!(out, "{:08x} {}", can.id, hex::encode(can.data()))?;
            }
            Transport::Uart | Transport::Spi => {
                let mut buf = [0u8; uart::MAX_FRAME_LEN];
                let len = uart::encode(&message, &mut buf)?;
                writeln!(out, "{}", hex::encode(&buf[..len]))?;
            }
            Transport::Ethernet => messages.push(message),
        }
    }
    if transport == Transport::Ethernet {
        let module_id = module_uuid.ok_or("--module-uuid is required with --transport ethernet")?;
        let max_datagram = max_datagram.max(ethernet::HEADER_LEN + uart::MAX_FRAME_LEN);
        let mut generator = ulid::Generator::new();
        let mut next_id = message_ulid;
        let mut buf = vec![0u8; max_datagram];
        let mut rest = &messages[..];
        loop {
            let id = match next_id {
                Some(id) => id,
                None => generator.generate()?,
            };
            next_id = match message_ulid {
                Some(_) => Some(id.increment().ok_or("the message ULID overflows")?),
                None => None,
            };
            let mut builder = PacketBuilder::new(&mut buf, id.to_bytes(), module_id)?;
            builder.set_max_len(max_datagram);
            while let Some((message, tail)) = rest.split_first() {
                if builder.push(message).is_err() {
                    break;
                }
                rest = tail;
            }
            writeln!(out, "{}", hex::encode(builder.finish()))?;
            if rest.is_empty() {
                break;
            }
        }
    }
    out.flush()?;
    Ok(exit_code(failed))
}

fn decode_can() -> Result<ExitCode, Box<dyn std::error::Error>> {
    let stdout = io::stdout();
    let mut out = io::BufWriter::new(stdout.lock());
    let mut failed = false;
    for (n, line) in io::stdin().lock().lines().enumerate() {
        let line = line?;
        let mut fields = line.split_whitespace();
        let Some(id) = fields.next() else {
            continue;
        };
        let data = fields.next().unwrap_or("");
        let message = u32::from_str_radix(id, 16)
            .map_err(|e| format!("identifier `{id}` is not hex: {e}"))
            .and_then(|id| {
                let data = hex::decode(data).map_err(|e| format!("data is not hex: {e}"))?;
                if let Some(extra) = fields.next() {
                    return Err(format!("unexpected `{extra}` after the data"));
                }
                Message::from_can(id, &data).map_err(|e| e.to_string())
            });
        match message {
            Ok(message) => print_message(&mut out, &message)?,
            Err(e) => {
                out.flush()?;
                eprintln!("stdin:{}: {e}", n + 1);
                failed = true;
            }
        }
    }
    out.flush()?;
    Ok(exit_code(failed))
}

fn decode_stream() -> Result<ExitCode, Box<dyn std::error::Error>> {
    let stdout = io::stdout();
    let mut out = io::BufWriter::new(stdout.lock());
    let mut parser = Parser::new();
    let mut hex_reader = HexReader::default();
    let mut bytes = Vec::new();
    let mut result = Ok(());
    for (n, line) in io::stdin().lock().lines().enumerate() {
        bytes.clear();
        if let Err(e) = hex_reader.push(&line?, &mut bytes) {
            result = Err(format!("stdin:{}:{e}", n + 1));
            break;
        }
        let mut write = Ok(());
        parser.feed_all(&bytes, |message| {
            if write.is_ok() {
                write = print_message(&mut out, &message);
            }
        });
        write?;
    }
    parser.finish();
    let stats = parser.stats();
    let summary = StatsJson {
        frames: stats.frames,
        crc_failures: stats.crc_failures,
        bad_length: stats.bad_length,
        decode_errors: stats.decode_errors,
        dropped: stats.dropped,
    };
    writeln!(out, "{}", serde_json::to_string(&summary)?)?;
    out.flush()?;
    if hex_reader.high.is_some() && result.is_ok() {
        result = Err("stdin: odd number of hex digits; the last one was ignored".into());
    }
    match result {
        Ok(()) => Ok(ExitCode::SUCCESS),
        Err(e) => {
            eprintln!("{e}");
            Ok(ExitCode::FAILURE)
        }
    }
}

fn decode_ethernet() -> Result<ExitCode, Box<dyn std::error::Error>> {
    let stdout = io::stdout();
    let mut out = io::BufWriter::new(stdout.lock());
    let mut failed = false;
    for (n, line) in io::stdin().lock().lines().enumerate() {
        let line = line?;
        let line: String = line.split_whitespace().collect();
        if line.is_empty() {
            continue;
        }
        let packet = hex::decode(&line).map_err(|e| format!("not hex: {e}"));
        let packet = packet.and_then(|bytes| {
            let packet = Packet::new_checked(&bytes).map_err(|e| e.to_string())?;
            Ok(packet.messages().collect::<Vec<_>>())
        });
        let messages = match packet {
            Ok(messages) => messages,
            Err(e) => {
                out.flush()?;
                eprintln!("stdin:{}: {e}", n + 1);
                failed = true;
                continue;
            }
        };
        for (i, message) in messages.iter().enumerate() {
            match message {
                Ok(message) => print_message(&mut out, message)?,
                Err(e) => {
                    out.flush()?;
                    eprintln!("stdin:{}: message {i}: {e}", n + 1);
                    failed = true;
                }
            }
        }
    }
    out.flush()?;
    Ok(exit_code(failed))
}
