//! The client against replies framed as the vehicle frames them.
#![allow(clippy::unwrap_used, clippy::panic, clippy::indexing_slicing)]

use super::*;
use crate::{decode_frame, Mode};

const NONCE: u32 = 0x5EED_0001;
const SESSION: u32 = 0x1234;

/// A vehicle's reply frame (replies carry session 0).
fn reply(seq: u16, r: &Reply) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    encode(0, seq, r, &mut buf).unwrap().to_vec()
}

/// Everything the client reports for `bytes`.
fn feed(c: &mut Client, bytes: &[u8]) -> Vec<Event> {
    let mut rest = bytes;
    let mut out = Vec::new();
    while !rest.is_empty() {
        if let Some(e) = c.receive(&mut rest) {
            out.push(e);
        }
    }
    out
}

/// The answers in `events`.
fn answers(events: &[Event]) -> Vec<Answer> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::Reply { answer, .. } => *answer,
            _ => None,
        })
        .collect()
}

/// What the vehicle reads in a frame: session, sequence number, command.
fn read(frame: &Frame) -> (u32, u16, Command) {
    match decode_frame::<Command>(frame.bytes()) {
        Some(Decoded::Frame { seq, session, msg }) => (session, seq, msg),
        other => panic!("not a frame: {other:?}"),
    }
}

fn opened() -> Client {
    let mut c = Client::default();
    c.open(NONCE, 0).unwrap();
    let ev = feed(
        &mut c,
        &reply(
            3,
            &Reply::Session {
                nonce: NONCE,
                session: SESSION,
            },
        ),
    );
    assert_eq!(answers(&ev), [Answer::Session { session: SESSION }]);
    c
}

#[test]
fn the_handshake_opens_the_session_the_vehicle_names_and_numbers_rise_from_1() {
    let mut c = Client::default();
    assert!(c.needs_session());
    assert_eq!(c.send(&Command::Arm, 0).unwrap_err(), SendError::NoSession);
    let open = c.open(NONCE, 0).unwrap();
    assert_eq!(read(&open), (0, 0, Command::OpenSession { nonce: NONCE }));
    assert!(c.is_opening());
    assert_eq!(c.send(&Command::Arm, 0).unwrap_err(), SendError::NoSession);
    // Another surface's answer (another nonce), a stray session number 0: not ours.
    let other = Reply::Session {
        nonce: NONCE + 1,
        session: 77,
    };
    let zero = Reply::Session {
        nonce: NONCE,
        session: 0,
    };
    for r in [other, zero] {
        let ev = feed(&mut c, &reply(1, &r));
        assert_eq!(ev.len(), 1);
        assert_eq!(answers(&ev), []);
        assert_eq!(c.session(), 0);
    }
    let ours = Reply::Session {
        nonce: NONCE,
        session: SESSION,
    };
    let ev = feed(&mut c, &reply(2, &ours));
    assert_eq!(answers(&ev), [Answer::Session { session: SESSION }]);
    assert_eq!(c.session(), SESSION);
    assert!(!c.is_opening() && !c.needs_session());
    for want in 1..=5u16 {
        let s = c.send(&Command::Heartbeat { t_us: 0 }, 0).unwrap();
        assert_eq!(s.seq, want);
        assert_eq!(
            read(&s.frame),
            (SESSION, want, Command::Heartbeat { t_us: 0 })
        );
    }
    assert_eq!(
        c.send(&Command::OpenSession { nonce: 1 }, 0).unwrap_err(),
        SendError::OpenSession
    );
    // A second answer with the nonce changes nothing: the session is open.
    let again = Reply::Session {
        nonce: NONCE,
        session: 99,
    };
    assert_eq!(answers(&feed(&mut c, &reply(4, &again))), []);
    assert_eq!(c.session(), SESSION);
}

#[test]
fn acks_and_nacks_are_matched_to_the_commands_of_the_session() {
    let mut c = opened();
    let arm = c.send(&Command::Arm, 0).unwrap().seq;
    let hb = c.send(&Command::Heartbeat { t_us: 0 }, 0).unwrap().seq;
    let mode = c.send(&Command::SetMode(Mode::Manual), 0).unwrap().seq;
    assert!(c.is_awaited(arm) && c.is_awaited(mode));
    assert!(
        !c.is_awaited(hb),
        "a heartbeat is answered by Status, not awaited"
    );
    let mut bytes = Vec::new();
    bytes.extend_from_slice(&reply(10, &Reply::Ack { seq: arm }));
    // Not sent in this session: a plain reply.
    bytes.extend_from_slice(&reply(11, &Reply::Ack { seq: 40 }));
    bytes.extend_from_slice(&reply(
        12,
        &Reply::Nack {
            seq: mode,
            reason: NackReason::Armed,
        },
    ));
    let ev = feed(&mut c, &bytes);
    assert_eq!(ev.len(), 3, "{ev:?}");
    assert_eq!(
        answers(&ev),
        [
            Answer::Command {
                seq: arm,
                result: Ok(())
            },
            Answer::Command {
                seq: mode,
                result: Err(NackReason::Armed)
            },
        ]
    );
    assert!(!c.is_awaited(arm) && !c.is_awaited(mode));
    assert_eq!(c.next_deadline(), None);
    assert_eq!(c.poll(u64::MAX), None);
    assert_eq!(c.frames_received(), 4);
}

#[test]
fn an_unanswered_command_times_out_once_and_a_late_answer_still_counts() {
    let mut c = opened();
    let a = c.send_within(&Command::Arm, 1_000, 500_000).unwrap().seq;
    let b = c.send(&Command::Disarm, 2_000).unwrap().seq;
    assert_eq!(c.next_deadline(), Some(501_000));
    assert_eq!(c.poll(500_999), None);
    assert_eq!(c.poll(501_000), Some(Event::TimedOut { seq: a }));
    assert_eq!(c.poll(501_000), None);
    assert_eq!(c.next_deadline(), Some(1_002_000));
    assert_eq!(c.poll(5_000_000), Some(Event::TimedOut { seq: b }));
    assert_eq!(c.poll(5_000_000), None);
    assert_eq!(c.next_deadline(), None);
    let ev = feed(&mut c, &reply(1, &Reply::Ack { seq: a }));
    assert_eq!(
        answers(&ev),
        [Answer::Command {
            seq: a,
            result: Ok(())
        }]
    );
}

#[test]
fn an_unanswered_or_refused_open_leaves_no_session() {
    let mut c = Client::new(ClientConfig {
        open_timeout_us: 100,
        answer_timeout_us: 10,
    });
    c.open(NONCE, 50).unwrap();
    assert_eq!(c.next_deadline(), Some(150));
    assert_eq!(c.poll(149), None);
    assert_eq!(c.poll(150), Some(Event::OpenTimedOut { nonce: NONCE }));
    assert!(!c.is_opening() && c.session() == 0);
    // A late answer opens nothing.
    let late = Reply::Session {
        nonce: NONCE,
        session: SESSION,
    };
    assert_eq!(answers(&feed(&mut c, &reply(1, &late))), []);
    assert_eq!(c.session(), 0);
    // A vehicle of another protocol version refuses the OpenSession (seq 0).
    c.open(NONCE, 200).unwrap();
    let refused = Reply::Nack {
        seq: 0,
        reason: NackReason::UnsupportedVersion,
    };
    assert_eq!(
        answers(&feed(&mut c, &reply(2, &refused))),
        [Answer::SessionRefused(NackReason::UnsupportedVersion)]
    );
    assert!(!c.is_opening() && c.needs_session());
    assert_eq!(c.poll(u64::MAX), None);
}

#[test]
fn a_new_session_starts_the_numbers_again_and_forgets_the_old_commands() {
    let mut c = opened();
    let old = c.send(&Command::Arm, 0).unwrap().seq;
    c.send(&Command::Arm, 0).unwrap();
    c.open(NONCE + 1, 0).unwrap();
    assert!(!c.is_awaited(old));
    let ours = Reply::Session {
        nonce: NONCE + 1,
        session: SESSION + 1,
    };
    feed(&mut c, &reply(5, &ours));
    assert_eq!(c.session(), SESSION + 1);
    let s = c.send(&Command::Disarm, 0).unwrap();
    assert_eq!(read(&s.frame), (SESSION + 1, 1, Command::Disarm));
    // The old session's second command (seq 2) is not one this session sent.
    assert_eq!(
        answers(&feed(&mut c, &reply(6, &Reply::Ack { seq: 2 }))),
        []
    );
    assert_eq!(c.poll(u64::MAX), Some(Event::TimedOut { seq: 1 }));
    assert_eq!(c.poll(u64::MAX), None);
}

#[test]
fn the_numbers_run_out_before_they_wrap() {
    let mut c = opened();
    let hb = Command::Heartbeat { t_us: 0 };
    let mut last = 0;
    while !c.needs_session() {
        last = c.send(&hb, 0).unwrap().seq;
    }
    assert_eq!(last, SEQ_LIMIT - 1);
    assert_eq!(c.send(&hb, 0).unwrap_err(), SendError::SeqExhausted);
    assert_eq!(c.next_seq(), SEQ_LIMIT);
}

#[test]
fn beyond_the_awaited_slots_the_command_due_first_is_forgotten() {
    let mut c = opened();
    let first = c.send_within(&Command::Arm, 0, 10).unwrap().seq;
    for k in 1..AWAITED as u64 {
        c.send_within(&Command::Arm, 0, 10 + k).unwrap();
    }
    assert_eq!(c.forgotten(), 0);
    let extra = c.send_within(&Command::Arm, 0, 1_000).unwrap().seq;
    assert_eq!(c.forgotten(), 1);
    assert!(!c.is_awaited(first) && c.is_awaited(extra));
    let mut timed_out = 0;
    while let Some(e) = c.poll(u64::MAX) {
        assert!(matches!(e, Event::TimedOut { .. }));
        timed_out += 1;
    }
    assert_eq!(timed_out, AWAITED);
}

#[test]
fn a_broken_frame_is_reported_and_the_next_one_is_read() {
    let mut c = opened();
    let arm = c.send(&Command::Arm, 0).unwrap().seq;
    let mut bytes = vec![1, 2, 3, 0, 0xFF, 0x55, 0x13, 0];
    bytes.extend_from_slice(&reply(9, &Reply::Ack { seq: arm }));
    let ev = feed(&mut c, &bytes);
    let drops = ev
        .iter()
        .filter(|e| matches!(e, Event::Dropped { .. }))
        .count();
    assert_eq!(drops, 2, "{ev:?}");
    assert_eq!(c.dropped().total(), 2);
    assert_eq!(
        answers(&ev),
        [Answer::Command {
            seq: arm,
            result: Ok(())
        }]
    );
}

#[test]
fn a_renewal_is_framed_in_the_session_it_renews_and_its_retry_with_a_higher_number() {
    let mut c = opened();
    for _ in 0..3 {
        c.send(&Command::Arm, 0).unwrap();
    }
    let next = c.next_seq();
    let renew = c.renew(NONCE + 1, 0).unwrap();
    assert_eq!(
        read(&renew),
        (SESSION, next, Command::OpenSession { nonce: NONCE + 1 })
    );
    assert!(c.is_opening());
    assert_eq!(c.send(&Command::Arm, 0).unwrap_err(), SendError::NoSession);
    // Not answered in time: the retry is in the same session, with a number above.
    assert_eq!(
        c.poll(c.config().open_timeout_us),
        Some(Event::OpenTimedOut { nonce: NONCE + 1 })
    );
    let retry = c.renew(NONCE + 2, 0).unwrap();
    assert_eq!(
        read(&retry),
        (SESSION, next + 1, Command::OpenSession { nonce: NONCE + 2 })
    );
    // A refusal names the renewal's number.
    let ev = feed(
        &mut c,
        &reply(
            4,
            &Reply::Nack {
                seq: next + 1,
                reason: NackReason::UnsupportedVersion,
            },
        ),
    );
    assert_eq!(
        answers(&ev),
        [Answer::SessionRefused(NackReason::UnsupportedVersion)]
    );
    // Answered: the new session's numbers start from 1; a later renewal is framed in it.
    c.renew(NONCE + 3, 0).unwrap();
    feed(
        &mut c,
        &reply(
            5,
            &Reply::Session {
                nonce: NONCE + 3,
                session: SESSION + 1,
            },
        ),
    );
    assert_eq!(c.session(), SESSION + 1);
    assert_eq!(c.send(&Command::Arm, 0).unwrap().seq, 1);
    let again = c.renew(NONCE + 4, 0).unwrap();
    assert_eq!(read(&again).0, SESSION + 1);
    assert_eq!(read(&again).1, 2);
}

#[test]
fn with_no_session_a_renewal_is_a_fresh_open_and_open_is_always_one() {
    let mut c = Client::default();
    let first = c.renew(NONCE, 0).unwrap();
    assert_eq!(read(&first), (0, 0, Command::OpenSession { nonce: NONCE }));
    let mut c = opened();
    let fresh = c.open(NONCE + 1, 0).unwrap();
    assert_eq!(
        read(&fresh),
        (0, 0, Command::OpenSession { nonce: NONCE + 1 })
    );
    // A fresh open not answered: a retry through `renew` is a fresh open too.
    let retry = c.renew(NONCE + 2, 0).unwrap();
    assert_eq!(
        read(&retry),
        (0, 0, Command::OpenSession { nonce: NONCE + 2 })
    );
}
