//! MAVLink frames from a ground station's bytes: each CRC-checked, parsed with the
//! ardupilotmega dialect, and garbage, cut or corrupted frames counted.
//!
//! The mission messages' `mission_type` (a MAVLink 2 extension the `mavlink` crate's
//! ardupilotmega messages leave out) is read from the payload, and answers for a type other
//! than the mission carry it (`send_typed`). A CRC-valid mission item whose frame or command
//! this dialect does not know cannot be parsed; it is kept as an [`UnknownItem`] so that
//! it is answered, not dropped.

use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::MavHeader;

/// A mission item (`MISSION_ITEM_INT` or `MISSION_ITEM`) whose frame or command this dialect
/// does not know: what is needed to answer it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UnknownItem {
    /// Its sequence number.
    pub seq: u16,
    /// Its addressee.
    pub target_system: u8,
    /// Its addressee's component.
    pub target_component: u8,
    /// Its frame is one this dialect knows (else the command is unknown).
    pub frame_known: bool,
    /// Its `mission_type`.
    pub mission_type: u8,
}

/// MAVLink message ids of the mission protocol and where `mission_type` sits in each
/// payload (after the base fields; absent when the sender truncated it as zero).
pub(super) const MISSION_TYPE_AT: [(u32, usize); 8] = [
    (39, 37), // MISSION_ITEM
    (40, 4),  // MISSION_REQUEST
    (43, 2),  // MISSION_REQUEST_LIST
    (44, 4),  // MISSION_COUNT
    (45, 2),  // MISSION_CLEAR_ALL
    (47, 3),  // MISSION_ACK
    (51, 4),  // MISSION_REQUEST_INT
    (73, 37), // MISSION_ITEM_INT
];

/// The `mission_type` of a mission message's payload (0, the mission, when absent).
fn mission_type_of(msgid: u32, payload: &[u8]) -> u8 {
    MISSION_TYPE_AT
        .iter()
        .find(|(id, _)| *id == msgid)
        .and_then(|&(_, at)| payload.get(at).copied())
        .unwrap_or(0)
}

/// A mission item's payload that would not parse: its fields by their wire offsets
/// (`MISSION_ITEM` and `MISSION_ITEM_INT` share them).
fn unknown_item(msgid: u32, payload: &[u8]) -> Option<UnknownItem> {
    use mavlink::Message;
    if msgid != 39 && msgid != 73 {
        return None;
    }
    // MAVLink 2 drops trailing zero bytes: pad to the base length.
    let mut p = [0u8; 38];
    let n = payload.len().min(p.len());
    p[..n].copy_from_slice(payload.get(..n)?);
    let [.., seq0, seq1, _, _, ts, tc, _, _, _, mission_type] = p;
    // With the command made a known one (MAV_CMD_NAV_WAYPOINT, 16), does it parse? Then the
    // frame is known and the command was not.
    let mut known_command = p;
    if let Some(c) = known_command.get_mut(30..32) {
        c.copy_from_slice(&16u16.to_le_bytes());
    }
    let frame_known = MavMessage::parse(mavlink::MavlinkVersion::V2, msgid, &known_command).is_ok();
    Some(UnknownItem {
        seq: u16::from_le_bytes([seq0, seq1]),
        target_system: ts,
        target_component: tc,
        frame_known,
        mission_type,
    })
}

/// The messages in `bytes` and how many malformed inputs were dropped from it. In a stream
/// an incomplete frame at the end stays in `bytes` for the next read; in a datagram it is
/// malformed. A garbage run counts once; a corrupted frame once (parsing resumes after its
/// first byte).
pub fn take_frames(bytes: &mut Vec<u8>, stream: bool) -> (Vec<(MavHeader, MavMessage)>, u64) {
    let (msgs, items, bad) = take_all_frames(bytes, stream);
    let msgs = msgs.into_iter().map(|(h, m, _)| (h, m)).collect();
    (msgs, bad + items.len() as u64)
}

/// A frame taken: its header, the message, its `mission_type`.
pub(super) type Taken = (MavHeader, MavMessage, u8);

/// [`take_frames`] with each message's `mission_type`, and the CRC-valid mission items
/// whose frame or command this dialect does not know.
pub(super) fn take_all_frames(
    bytes: &mut Vec<u8>,
    stream: bool,
) -> (Vec<Taken>, Vec<(MavHeader, UnknownItem)>, u64) {
    use mavlink::Message;
    let mut out = Vec::new();
    let mut items = Vec::new();
    let mut bad = 0;
    let mut i = 0;
    while i < bytes.len() {
        let Some(skip) = bytes[i..].iter().position(|&b| b == 0xFD || b == 0xFE) else {
            bad += 1;
            i = bytes.len();
            break;
        };
        if skip > 0 {
            bad += 1;
            i += skip;
        }
        let rest = &bytes[i..];
        // MAVLink 2: magic, length, incompatibility flags (bit 0: signed, 13 bytes more),
        // ... 10 header bytes, payload, 2 CRC; MAVLink 1: 6 header bytes, payload, 2 CRC.
        let need = match (rest[0], rest.get(1), rest.get(2)) {
            (0xFD, Some(&len), Some(&flags)) => {
                Some(12 + usize::from(len) + if flags & 1 != 0 { 13 } else { 0 })
            }
            (0xFE, Some(&len), _) => Some(8 + usize::from(len)),
            _ => None,
        };
        match need {
            Some(need) if rest.len() >= need => {
                let mut reader = mavlink::MavlinkReader::new(&rest[..need]);
                match reader.read_any_raw_message::<MavMessage>() {
                    Ok(raw) => {
                        let header = MavHeader {
                            system_id: raw.system_id(),
                            component_id: raw.component_id(),
                            sequence: raw.sequence(),
                        };
                        let (id, payload) = (raw.message_id(), raw.payload());
                        match MavMessage::parse(raw.version(), id, payload) {
                            Ok(m) => out.push((header, m, mission_type_of(id, payload))),
                            Err(_) => match unknown_item(id, payload) {
                                Some(item) => items.push((header, item)),
                                None => bad += 1,
                            },
                        }
                        i += need;
                    }
                    Err(_) => {
                        bad += 1;
                        i += 1;
                    }
                }
            }
            // Incomplete: the rest of the frame comes with the next read of a stream.
            _ if stream => break,
            _ => {
                bad += 1;
                i += 1;
            }
        }
    }
    bytes.drain(..i);
    (out, items, bad)
}

/// `text` in lines of at most `width` characters, broken at spaces where it can be.
pub fn split_text(text: &str, width: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut line = String::new();
    for word in text.split(' ') {
        let mut word = word.to_string();
        while word.chars().count() > width {
            if !line.is_empty() {
                lines.push(std::mem::take(&mut line));
            }
            let head: String = word.chars().take(width).collect();
            word = word.chars().skip(width).collect();
            lines.push(head);
        }
        let extra = usize::from(!line.is_empty());
        if line.chars().count() + extra + word.chars().count() > width {
            lines.push(std::mem::take(&mut line));
        } else if extra == 1 {
            line.push(' ');
        }
        line.push_str(&word);
    }
    if !line.is_empty() || lines.is_empty() {
        lines.push(line);
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::ardupilotmega::{MavCmd, MavFrame, MISSION_ITEM_INT_DATA};

    #[test]
    fn mission_type_is_read_past_the_base_fields_and_an_unknown_command_is_kept() {
        assert_eq!(mission_type_of(45, &[1, 1]), 0);
        assert_eq!(mission_type_of(45, &[1, 1, 1]), 1);
        assert_eq!(mission_type_of(44, &[3, 0, 1, 1, 2]), 2);
        assert_eq!(mission_type_of(0, &[9, 9, 9, 9, 9]), 0);
        // A MISSION_ITEM_INT with command 64999 (none of this dialect's): CRC-valid, kept.
        let item = MavMessage::MISSION_ITEM_INT(MISSION_ITEM_INT_DATA {
            seq: 7,
            command: MavCmd::MAV_CMD_NAV_WAYPOINT,
            frame: MavFrame::MAV_FRAME_LOCAL_NED,
            target_system: 1,
            target_component: 1,
            ..Default::default()
        });
        let mut frame = Vec::new();
        mavlink::write_v2_msg(&mut frame, MavHeader::default(), &item).unwrap();
        // The payload starts after 10 bytes; the command sits at payload offset 30.
        frame[10 + 30..10 + 32].copy_from_slice(&64999u16.to_le_bytes());
        let n = frame.len();
        let crc = mavlink::calculate_crc(&frame[1..n - 2], {
            use mavlink::Message;
            MavMessage::extra_crc(73)
        });
        frame[n - 2..].copy_from_slice(&crc.to_le_bytes());
        let (msgs, items, bad) = take_all_frames(&mut frame, false);
        assert_eq!((msgs.len(), bad), (0, 0));
        assert_eq!(items.len(), 1);
        let it = items[0].1;
        assert_eq!((it.seq, it.frame_known, it.mission_type), (7, true, 0));
    }
}
