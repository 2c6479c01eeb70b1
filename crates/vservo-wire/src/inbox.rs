//! Taking messages off a subscriber: the one place a message of another schema is refused. Every
//! subscriber of a payload gets [`TakeMessages`]; a caller says what it does with each accepted message
//! and counts the refused ones, and never compares a schema itself.

use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{ZeroCopySend, ipc};

use crate::SCHEMA_VERSION;

/// A payload that starts with the schema version (every service's message).
pub trait Payload: Copy + std::fmt::Debug + ZeroCopySend + 'static {
    /// The schema version the message says it was written in.
    fn schema(&self) -> u32;
}

/// A message taken off a service and refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Refused {
    /// Written in another schema (another build of vservo, or not a vservo message).
    #[error("schema {found}, this build reads schema {SCHEMA_VERSION}")]
    Schema {
        /// The schema the message says.
        found: u32,
    },
}

/// Checks a message's schema: the message, or why it is refused.
pub fn accept<T: Payload>(message: T) -> Result<T, Refused> {
    match message.schema() {
        SCHEMA_VERSION => Ok(message),
        found => Err(Refused::Schema { found }),
    }
}

/// Taking the messages that arrived on a subscriber, refusing those of another schema.
pub trait TakeMessages<T: Payload> {
    /// The next message waiting: `None` when none is (or the service cannot be read); `Some(Err)` for a
    /// message taken off the queue and refused.
    fn next_message(&self) -> Option<Result<T, Refused>>;

    /// The next message waiting and the pid of the process that sent it (its iceoryx2 node's, from the sample's
    /// header; `None` when it cannot be told).
    fn next_sent(&self) -> Option<(Result<T, Refused>, Option<i32>)>;

    /// Takes every message waiting: `accepted` gets each acceptable one in order; returns how many were
    /// refused.
    fn each_message(&self, mut accepted: impl FnMut(T)) -> u64 {
        let mut refused = 0;
        while let Some(taken) = self.next_message() {
            match taken {
                Ok(message) => accepted(message),
                Err(_) => refused += 1,
            }
        }
        refused
    }

    /// Takes every message waiting and keeps the newest acceptable one; `refused` counts the others.
    fn newest_message(&self, refused: &mut u64) -> Option<T> {
        let mut newest = None;
        *refused += self.each_message(|message| newest = Some(message));
        newest
    }
}

impl<T: Payload> TakeMessages<T> for Subscriber<ipc::Service, T, ()> {
    fn next_message(&self) -> Option<Result<T, Refused>> {
        match self.receive() {
            Ok(Some(sample)) => Some(accept(*sample)),
            Ok(None) | Err(_) => None,
        }
    }

    fn next_sent(&self) -> Option<(Result<T, Refused>, Option<i32>)> {
        use iceoryx2::prelude::PayloadHeader;
        match self.receive() {
            Ok(Some(sample)) => {
                let sender = sample.header().node_id().pid::<ipc::Service>().ok().map(|pid| pid.value());
                Some((accept(*sample), sender))
            }
            Ok(None) | Err(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{CommandMsg, FeaturesMsg};

    #[test]
    fn a_message_of_another_schema_is_refused_naming_both() {
        let command = CommandMsg { schema: SCHEMA_VERSION, ..CommandMsg::default() };
        assert_eq!(accept(command), Ok(command));
        let old = FeaturesMsg { schema: SCHEMA_VERSION - 1, ..FeaturesMsg::default() };
        let refused = accept(old).err();
        assert_eq!(refused, Some(Refused::Schema { found: SCHEMA_VERSION - 1 }));
        assert_eq!(
            refused.map(|r| r.to_string()),
            Some(format!("schema {}, this build reads schema {SCHEMA_VERSION}", SCHEMA_VERSION - 1))
        );
    }
}
