//! Seals on the daemon's own messages (`gains`, `object`, `cell_mode`) and the rmrc's `joint_command`, so
//! that the nodes take them from the daemon (and the simulated driver from the rmrc) only. Any process of the daemon's user can publish on an instance's services; what it cannot do is seal
//! a message: the seal is SipHash-2-4 of the message's fields, keyed with a secret the daemon draws from
//! the system's random source at start and hands each node on its stdin (never in a message, an argument
//! or the environment). A stray or rogue `gains` or `object` is refused and counted. SipHash-2-4 is
//! written out here (forty lines, checked against the reference vector of its paper) rather than taken
//! from a crate for four messages. The joint command is sealed on the 1 ms path: its bytes go through a
//! buffer on the stack, nothing is allocated.

use crate::{CellModeMsg, GainsMsg, JointCommandMsg, ObjectMsg};

/// Fills a fixed buffer with little-endian words (no allocation).
struct Words<const N: usize> {
    bytes: [u8; N],
    len: usize,
}

impl<const N: usize> Words<N> {
    fn new() -> Self {
        Self { bytes: [0; N], len: 0 }
    }

    fn put(&mut self, value: &[u8]) -> &mut Self {
        self.bytes[self.len..self.len + value.len()].copy_from_slice(value);
        self.len += value.len();
        self
    }

    fn floats(&mut self, values: &[f64]) -> &mut Self {
        for v in values {
            self.put(&v.to_bits().to_le_bytes());
        }
        self
    }

    fn bytes(&self) -> &[u8] {
        &self.bytes[..self.len]
    }
}

/// The 128-bit key of an instance's run.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct SealKey {
    k0: u64,
    k1: u64,
}

impl std::fmt::Debug for SealKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SealKey(…)")
    }
}

impl SealKey {
    /// A fresh key from the system's random source.
    pub fn random() -> std::io::Result<Self> {
        use std::io::Read;
        let mut bytes = [0u8; 16];
        std::fs::File::open("/dev/urandom")?.read_exact(&mut bytes)?;
        Ok(Self::from_bytes(bytes))
    }

    fn from_bytes(bytes: [u8; 16]) -> Self {
        let (a, b) = bytes.split_at(8);
        let word = |s: &[u8]| u64::from_le_bytes(std::array::from_fn(|i| s[i]));
        Self { k0: word(a), k1: word(b) }
    }

    /// The key as 32 hexadecimal digits (how the daemon hands it to a node).
    pub fn to_hex(&self) -> String {
        format!("{:016x}{:016x}", self.k0, self.k1)
    }

    /// The key from [`SealKey::to_hex`]'s text.
    pub fn from_hex(text: &str) -> Option<Self> {
        let text = text.trim();
        if text.len() != 32 || !text.is_ascii() {
            return None;
        }
        Some(Self {
            k0: u64::from_str_radix(&text[..16], 16).ok()?,
            k1: u64::from_str_radix(&text[16..], 16).ok()?,
        })
    }

    /// The seal of a gains message (its `seal` field left out).
    pub fn seal_gains(&self, m: &GainsMsg) -> u64 {
        let mut bytes = Vec::with_capacity(24 + 8 * (48 + 144 + 8 + 4 + 64 + 36 + 1));
        bytes.extend_from_slice(&m.schema.to_le_bytes());
        bytes.extend_from_slice(&m.used_past_gains.to_le_bytes());
        bytes.extend_from_slice(&m.version.to_le_bytes());
        bytes.extend_from_slice(&m.interaction.to_le_bytes());
        bytes.extend_from_slice(&m.feedforward.to_le_bytes());
        let numbers = m.feature_gain.iter().chain(&m.past_input_gains).chain(&m.desired_features_px);
        let design = m.desired_depths_m.iter().chain(&m.q).chain(&m.r_si).chain([&m.border_margin_px]);
        for v in numbers.chain(design) {
            bytes.extend_from_slice(&v.to_bits().to_le_bytes());
        }
        siphash24(self.k0, self.k1, &bytes)
    }

    /// The seal of an object message (its `seal` field left out).
    pub fn seal_object(&self, m: &ObjectMsg) -> u64 {
        let mut bytes = Vec::with_capacity(64);
        bytes.extend_from_slice(&m.schema.to_le_bytes());
        bytes.extend_from_slice(&m.kind.to_le_bytes());
        bytes.extend_from_slice(&m.sequence.to_le_bytes());
        for v in m.translation_m.iter().chain([&m.radius_m, &m.rev_per_min]) {
            bytes.extend_from_slice(&v.to_bits().to_le_bytes());
        }
        siphash24(self.k0, self.k1, &bytes)
    }

    /// The seal of a joint command (its `seal` field left out); allocates nothing.
    pub fn seal_joint_command(&self, m: &JointCommandMsg) -> u64 {
        let mut words = Words::<{ 8 + 32 + 3 * 48 + 24 }>::new();
        words
            .put(&m.schema.to_le_bytes())
            .put(&m.mode.to_le_bytes())
            .put(&m.answers_tick.to_le_bytes())
            .put(&m.driver_epoch.to_le_bytes())
            .put(&m.state_stamp_ns.to_le_bytes())
            .put(&m.stamp_ns.to_le_bytes())
            .floats(&m.torque_nm)
            .floats(&m.q_ref_rad)
            .floats(&m.qd_ref_rad_s)
            .put(&m.twist_capture_tick.to_le_bytes())
            .put(&m.twist_applied_tick.to_le_bytes())
            .put(&m.reference_since_tick.to_le_bytes());
        siphash24(self.k0, self.k1, words.bytes())
    }

    /// The seal of a cell mode (its `seal` field left out); allocates nothing.
    pub fn seal_cell_mode(&self, m: &CellModeMsg) -> u64 {
        let mut words = Words::<32>::new();
        words
            .put(&m.schema.to_le_bytes())
            .put(&m.mode.to_le_bytes())
            .put(&m.sequence.to_le_bytes())
            .put(&m.fault.to_le_bytes())
            .put(&m.fault_joints.to_le_bytes())
            .put(&m.stamp_ns.to_le_bytes());
        siphash24(self.k0, self.k1, words.bytes())
    }
}

/// SipHash-2-4 (Aumasson & Bernstein 2012) of `data` under the key (k0, k1).
pub fn siphash24(k0: u64, k1: u64, data: &[u8]) -> u64 {
    let mut v = [
        k0 ^ 0x736f_6d65_7073_6575,
        k1 ^ 0x646f_7261_6e64_6f6d,
        k0 ^ 0x6c79_6765_6e65_7261,
        k1 ^ 0x7465_6462_7974_6573,
    ];
    fn round(v: &mut [u64; 4]) {
        v[0] = v[0].wrapping_add(v[1]);
        v[1] = v[1].rotate_left(13) ^ v[0];
        v[0] = v[0].rotate_left(32);
        v[2] = v[2].wrapping_add(v[3]);
        v[3] = v[3].rotate_left(16) ^ v[2];
        v[0] = v[0].wrapping_add(v[3]);
        v[3] = v[3].rotate_left(21) ^ v[0];
        v[2] = v[2].wrapping_add(v[1]);
        v[1] = v[1].rotate_left(17) ^ v[2];
        v[2] = v[2].rotate_left(32);
    }
    let compress = |m: u64, v: &mut [u64; 4]| {
        v[3] ^= m;
        round(v);
        round(v);
        v[0] ^= m;
    };
    let chunks = data.chunks_exact(8);
    let tail = chunks.remainder();
    for chunk in chunks {
        compress(u64::from_le_bytes(std::array::from_fn(|i| chunk[i])), &mut v);
    }
    let mut last = (data.len() as u64 & 0xff) << 56;
    for (i, byte) in tail.iter().enumerate() {
        last |= u64::from(*byte) << (8 * i);
    }
    compress(last, &mut v);
    v[2] ^= 0xff;
    for _ in 0..4 {
        round(&mut v);
    }
    v[0] ^ v[1] ^ v[2] ^ v[3]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn siphash_2_4_gives_the_reference_vector_of_its_paper() {
        // key 00 01 … 0f, message 00 01 … 0e: a129ca6149be45e5 (SipHash paper, appendix A)
        let key = SealKey::from_bytes(std::array::from_fn(|i| i as u8));
        let message: Vec<u8> = (0u8..15).collect();
        assert_eq!(siphash24(key.k0, key.k1, &message), 0xa129_ca61_49be_45e5);
    }

    #[test]
    fn a_seal_holds_for_its_message_only_and_under_its_key_only() {
        let key = SealKey::random().expect("a key");
        assert_eq!(SealKey::from_hex(&key.to_hex()), Some(key));
        let mut object = ObjectMsg {
            schema: crate::SCHEMA_VERSION,
            kind: crate::command_kind::OBJECT_CIRCLE,
            sequence: 3,
            translation_m: [0.0; 3],
            radius_m: 0.1,
            rev_per_min: 5.0,
            seal: 0,
        };
        let seal = key.seal_object(&object);
        object.seal = seal;
        assert_eq!(key.seal_object(&object), seal, "the seal field is not sealed");
        let other = SealKey::random().expect("another key");
        assert_ne!(other.seal_object(&object), seal);
        object.rev_per_min = 1000.0;
        assert_ne!(key.seal_object(&object), seal);
        assert_eq!(SealKey::from_hex("not hex at all, thirty-two chars"), None);
    }

    #[test]
    fn joint_commands_and_cell_modes_are_sealed_over_every_field() {
        let key = SealKey::random().expect("a key");
        let command = crate::JointCommandMsg {
            schema: crate::SCHEMA_VERSION,
            mode: crate::command_mode::TORQUE,
            answers_tick: 7,
            driver_epoch: 1,
            state_stamp_ns: 10,
            stamp_ns: 11,
            torque_nm: [1.0; 6],
            q_ref_rad: [0.5; 6],
            qd_ref_rad_s: [0.0; 6],
            twist_capture_tick: 0,
            twist_applied_tick: 2,
            reference_since_tick: 1,
            seal: 0,
        };
        let seal = key.seal_joint_command(&command);
        assert_eq!(key.seal_joint_command(&crate::JointCommandMsg { seal, ..command }), seal);
        for changed in [
            crate::JointCommandMsg { answers_tick: 8, ..command },
            crate::JointCommandMsg { stamp_ns: 12, ..command },
            crate::JointCommandMsg { torque_nm: [1.0, 1.0, 1.0, 1.0, 1.0, 1e9], ..command },
            crate::JointCommandMsg { qd_ref_rad_s: [0.0, 0.0, 0.0, 0.0, 0.0, 1e-9], ..command },
            crate::JointCommandMsg { twist_applied_tick: 3, ..command },
            crate::JointCommandMsg { reference_since_tick: 4, ..command },
        ] {
            assert_ne!(key.seal_joint_command(&changed), seal);
        }
        let mode = crate::CellModeMsg {
            schema: crate::SCHEMA_VERSION,
            mode: crate::cell_mode::SAFE_STOP,
            sequence: 2,
            fault: crate::fault::TARGET_LOST,
            fault_joints: 0,
            stamp_ns: 5,
            seal: 0,
        };
        let seal = key.seal_cell_mode(&mode);
        assert_ne!(
            key.seal_cell_mode(&crate::CellModeMsg { mode: crate::cell_mode::SERVOING, ..mode }),
            seal
        );
        assert_ne!(key.seal_cell_mode(&crate::CellModeMsg { sequence: 3, ..mode }), seal);
        assert_ne!(SealKey::random().expect("a key").seal_cell_mode(&mode), seal);
    }
}
