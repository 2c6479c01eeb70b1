//! Seals on the daemon's own messages (`gains`, `object`, `cell_mode`) and the rmrc's `joint_command`, so
//! that the nodes take them from the daemon (and the simulated driver from the rmrc) only. Any process of
//! the daemon's user can publish on an instance's services; what it cannot do is seal a message: the seal
//! is SipHash-2-4 of the message's fields, keyed with a secret the daemon draws from the system's random
//! source at start and hands each node on its stdin (never in a message, an argument or the environment).
//! A stray or rogue `gains` or `object` is refused and counted. The processes that hold the key make their
//! memory private first ([`keep_memory_private`]), its text is wiped once used ([`SealKey::to_hex`] gives it
//! in a buffer wiped when dropped) and the key wipes itself when dropped; which sealed message is newer is
//! `crate::freshness`'s rule. SipHash-2-4 is written out here (sixty
//! lines, checked against the reference vector of its paper) rather than taken from a crate for four
//! messages. The bytes are each message's fields in order, fed to the hash field by field as its one
//! declaration writes them: the joint command is sealed on the 1 ms path and nothing is allocated.

use zeroize::{Zeroize, Zeroizing};

use crate::declare::WireMessage;

/// The 128-bit key of an instance's run. Wiped when dropped (each clone too); never printed.
#[derive(Clone, PartialEq, Eq)]
pub struct SealKey {
    k0: u64,
    k1: u64,
}

impl Drop for SealKey {
    fn drop(&mut self) {
        self.k0.zeroize();
        self.k1.zeroize();
    }
}

/// The length of the key's text: 32 hexadecimal digits.
pub const KEY_HEX_DIGITS: usize = 32;

/// Makes this process's memory unreadable to other processes of its user, before it holds the key: not
/// dumpable (`prctl(PR_SET_DUMPABLE, 0)`: no `/proc/<pid>/mem`, `process_vm_readv` or ptrace attach by a
/// process without `CAP_SYS_PTRACE`, and the files in `/proc/<pid>/` root's) and no core dump (`RLIMIT_CORE`
/// 0, the hard limit too). Call it first in `main` of every process that receives the key (docs/PROTOCOL.md,
/// "Seals"); threads inherit it, `execve` does not (each node calls it itself).
pub fn keep_memory_private() -> Result<(), nix::Error> {
    nix::sys::prctl::set_dumpable(false)?;
    nix::sys::resource::setrlimit(nix::sys::resource::Resource::RLIMIT_CORE, 0, 0)
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
        let mut bytes = Zeroizing::new([0u8; 16]);
        std::fs::File::open("/dev/urandom")?.read_exact(&mut bytes[..])?;
        Ok(Self::from_bytes(&bytes))
    }

    fn from_bytes(bytes: &[u8; 16]) -> Self {
        let (a, b) = bytes.split_at(8);
        let word = |s: &[u8]| u64::from_le_bytes(std::array::from_fn(|i| s[i]));
        Self { k0: word(a), k1: word(b) }
    }

    /// The key as 32 hexadecimal digits (how the daemon hands it to a node), in a buffer wiped when dropped.
    pub fn to_hex(&self) -> Zeroizing<[u8; KEY_HEX_DIGITS]> {
        const DIGITS: &[u8; 16] = b"0123456789abcdef";
        let mut text = Zeroizing::new([0u8; KEY_HEX_DIGITS]);
        for (i, word) in [self.k0, self.k1].into_iter().enumerate() {
            for nibble in 0..16 {
                let value = (word >> (60 - 4 * nibble)) & 0xf;
                text[16 * i + nibble] = DIGITS[value as usize];
            }
        }
        text
    }

    /// The key from [`SealKey::to_hex`]'s text (surrounding white space ignored); no copy of the text is made.
    pub fn from_hex(text: &[u8]) -> Option<Self> {
        let text = text.trim_ascii();
        if text.len() != KEY_HEX_DIGITS {
            return None;
        }
        let word = |digits: &[u8]| {
            digits.iter().try_fold(0u64, |word, digit| {
                let value = char::from(*digit).to_digit(16)?;
                Some((word << 4) | u64::from(value))
            })
        };
        Some(Self { k0: word(&text[..16])?, k1: word(&text[16..])? })
    }

    /// The seal of a message: SipHash-2-4 of every field but `seal`, in order, little-endian (the bytes its
    /// declaration writes, `crate::declare`); allocates nothing.
    pub fn seal<M: WireMessage>(&self, message: &M) -> u64 {
        let mut hasher = SipHasher24::new(self.k0, self.k1);
        message.write_sealed_bytes(&mut |bytes| hasher.write(bytes));
        hasher.finish()
    }
}

/// A message that carries a seal in its `seal` field.
pub trait Sealed: WireMessage {
    /// The seal it carries.
    fn carried_seal(&self) -> u64;
    /// Puts `seal` in its `seal` field.
    fn put_seal(&mut self, seal: u64);
}

macro_rules! sealed_messages {
    ($($message:ty),*) => {$(
        impl Sealed for $message {
            fn carried_seal(&self) -> u64 {
                self.seal
            }
            fn put_seal(&mut self, seal: u64) {
                self.seal = seal;
            }
        }
    )*};
}

sealed_messages!(
    crate::JointCommandMsg,
    crate::FeaturesMsg,
    crate::CameraTwistMsg,
    crate::GainsMsg,
    crate::ObjectMsg,
    crate::CellModeMsg
);

impl SealKey {
    /// Seals `message` under this key.
    pub fn sign<M: Sealed>(&self, message: &mut M) {
        message.put_seal(self.seal(message));
    }

    /// Whether `message` carries this key's seal.
    pub fn verifies<M: Sealed>(&self, message: &M) -> bool {
        self.seal(message) == message.carried_seal()
    }
}

/// Seals `message` with `key`; without a key (a node started by hand) the seal is 0, which no key verifies
/// but by chance.
pub fn sign_with<M: Sealed>(key: Option<&SealKey>, message: &mut M) {
    message.put_seal(key.map_or(0, |key| key.seal(message)));
}

/// Whether `message` carries the seal of `key`; without a key nothing is sealed.
pub fn sealed_by<M: Sealed>(key: Option<&SealKey>, message: &M) -> bool {
    key.is_some_and(|key| key.verifies(message))
}

/// The first line of what the daemon writes on the stdin of a process it hands the key to (its nodes, and the
/// drivers it starts): this, the key's 32 digits, a newline.
pub const SEAL_KEY_LINE: &str = "vservo-seal-key=";

/// The longest key line: [`SEAL_KEY_LINE`], the key's digits and the newline.
pub const KEY_LINE_BYTES: usize = SEAL_KEY_LINE.len() + KEY_HEX_DIGITS + 1;

/// Writes the key line of `key` to `out` (no copy of the key's text is left behind).
pub fn write_key_line(key: &SealKey, out: &mut impl std::io::Write) -> std::io::Result<()> {
    out.write_all(SEAL_KEY_LINE.as_bytes())?;
    out.write_all(&key.to_hex()[..])?;
    out.write_all(b"\n")
}

/// Reads a first line from `input` byte by byte (unbuffered: read it from the file descriptor itself, as std's
/// `Stdin` keeps a copy of what it read), into a buffer wiped once parsed: the key if it is a key line, else
/// the bytes read, which are the beginning of what follows (a node's configuration). A key line whose digits
/// are not a key is an error.
pub fn read_key_line(input: &mut impl std::io::Read) -> std::io::Result<(Option<SealKey>, Vec<u8>)> {
    let mut line = Zeroizing::new([0u8; KEY_LINE_BYTES]);
    let mut length = 0;
    while length < KEY_LINE_BYTES {
        let mut byte = [0u8; 1];
        if input.read(&mut byte)? == 0 {
            break;
        }
        line[length] = byte[0];
        byte.zeroize();
        length += 1;
        if line[length - 1] == b'\n' {
            break;
        }
    }
    let line = &line[..length];
    if line.starts_with(SEAL_KEY_LINE.as_bytes()) {
        let key = parse_key_line(line).ok_or_else(|| {
            std::io::Error::new(std::io::ErrorKind::InvalidData, "the key line is not 32 hexadecimal digits")
        })?;
        Ok((Some(key), Vec::new()))
    } else {
        Ok((None, line.to_vec()))
    }
}

/// The key of a key line ([`SEAL_KEY_LINE`], 32 hexadecimal digits, a newline).
fn parse_key_line(line: &[u8]) -> Option<SealKey> {
    let digits = line.strip_prefix(SEAL_KEY_LINE.as_bytes())?.strip_suffix(b"\n")?;
    SealKey::from_hex(digits)
}

/// SipHash-2-4 (Aumasson & Bernstein 2012), fed in pieces: the bytes of a message field by field, with
/// no buffer but the last incomplete word.
struct SipHasher24 {
    v: [u64; 4],
    /// The bytes of the word being filled, little-endian.
    tail: u64,
    /// How many bytes `tail` holds.
    tail_len: usize,
    length: u64,
}

impl Drop for SipHasher24 {
    /// The state starts as the key xor constants: wiped once the seal is out (four stores, no allocation).
    fn drop(&mut self) {
        self.v.zeroize();
        self.tail.zeroize();
    }
}

impl SipHasher24 {
    fn new(k0: u64, k1: u64) -> Self {
        let v = [
            k0 ^ 0x736f_6d65_7073_6575,
            k1 ^ 0x646f_7261_6e64_6f6d,
            k0 ^ 0x6c79_6765_6e65_7261,
            k1 ^ 0x7465_6462_7974_6573,
        ];
        Self { v, tail: 0, tail_len: 0, length: 0 }
    }

    fn round(&mut self) {
        let v = &mut self.v;
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

    fn compress(&mut self, word: u64) {
        self.v[3] ^= word;
        self.round();
        self.round();
        self.v[0] ^= word;
    }

    fn write(&mut self, bytes: &[u8]) {
        for &byte in bytes {
            self.tail |= u64::from(byte) << (8 * self.tail_len);
            self.tail_len += 1;
            if self.tail_len == 8 {
                let word = self.tail;
                self.compress(word);
                self.tail = 0;
                self.tail_len = 0;
            }
        }
        self.length = self.length.wrapping_add(bytes.len() as u64);
    }

    fn finish(mut self) -> u64 {
        let last = ((self.length & 0xff) << 56) | self.tail;
        self.compress(last);
        self.v[2] ^= 0xff;
        for _ in 0..4 {
            self.round();
        }
        self.v[0] ^ self.v[1] ^ self.v[2] ^ self.v[3]
    }
}

/// SipHash-2-4 of `data` under the key (k0, k1).
pub fn siphash24(k0: u64, k1: u64, data: &[u8]) -> u64 {
    let mut hasher = SipHasher24::new(k0, k1);
    hasher.write(data);
    hasher.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ObjectMsg;

    #[test]
    fn siphash_2_4_gives_the_reference_vector_of_its_paper() {
        // key 00 01 … 0f, message 00 01 … 0e: a129ca6149be45e5 (SipHash paper, appendix A)
        let key = SealKey::from_bytes(&std::array::from_fn(|i| i as u8));
        let message: Vec<u8> = (0u8..15).collect();
        assert_eq!(siphash24(key.k0, key.k1, &message), 0xa129_ca61_49be_45e5);
    }

    #[test]
    fn siphash_fed_in_pieces_equals_siphash_fed_at_once() {
        let data: Vec<u8> = (0u8..=200).collect();
        for split in [0, 1, 7, 8, 9, 63, 64, 65, 200] {
            let mut hasher = SipHasher24::new(3, 5);
            let (a, b) = data.split_at(split);
            hasher.write(a);
            hasher.write(b);
            assert_eq!(hasher.finish(), siphash24(3, 5, &data), "split at {split}");
        }
    }

    #[test]
    fn a_key_line_gives_the_key_and_nothing_else_does() {
        let key = SealKey::random().expect("a key");
        let mut line = Vec::new();
        write_key_line(&key, &mut line).expect("written");
        assert_eq!(line.len(), KEY_LINE_BYTES);
        assert_eq!(parse_key_line(&line), Some(key.clone()));
        assert_eq!(parse_key_line(&line[..line.len() - 1]), None, "no newline: cut short");
        assert_eq!(parse_key_line(b"[instance]\n"), None);
        line.extend_from_slice(b"[instance]\n");
        let (read, rest) = read_key_line(&mut line.as_slice()).expect("read");
        assert_eq!((read, rest), (Some(key), Vec::new()), "the line only, not what follows");
        let (read, rest) = read_key_line(&mut &b"[instance]\nname = 'a'\n"[..]).expect("read");
        assert_eq!((read, rest.as_slice()), (None, &b"[instance]\n"[..]));
        assert!(read_key_line(&mut &b"vservo-seal-key=zz\n"[..]).is_err());
    }

    #[test]
    fn a_seal_holds_for_its_message_only_and_under_its_key_only() {
        let key = SealKey::random().expect("a key");
        assert_eq!(SealKey::from_hex(&key.to_hex()[..]), Some(key.clone()));
        let mut object = ObjectMsg {
            kind: crate::CommandKind::ObjectCircle.into(),
            sequence: 3,
            radius_m: 0.1,
            rev_per_min: 5.0,
            ..ObjectMsg::default()
        };
        let seal = key.seal(&object);
        object.seal = seal;
        assert_eq!(key.seal(&object), seal, "the seal field is not sealed");
        let other = SealKey::random().expect("another key");
        assert_ne!(other.seal(&object), seal);
        object.rev_per_min = 1000.0;
        assert_ne!(key.seal(&object), seal);
        assert_eq!(SealKey::from_hex(b"not hex at all, thirty-two chars"), None);
    }

    #[test]
    fn joint_commands_and_cell_modes_are_sealed_over_every_field() {
        let key = SealKey::random().expect("a key");
        let command = crate::JointCommandMsg {
            mode: crate::CommandMode::Torque.into(),
            answers_tick: 7,
            driver_epoch: 1,
            state_stamp_ns: 10,
            stamp_ns: 11,
            torque_nm: [1.0; 7],
            q_ref_rad: [0.5; 7],
            twist_capture_tick: 0,
            twist_applied_tick: 2,
            reference_since_tick: 1,
            ..crate::JointCommandMsg::default()
        };
        let seal = key.seal(&command);
        assert_eq!(key.seal(&crate::JointCommandMsg { seal, ..command }), seal);
        for changed in [
            crate::JointCommandMsg { answers_tick: 8, ..command },
            crate::JointCommandMsg { joint_count: 7, ..command },
            crate::JointCommandMsg { stamp_ns: 12, ..command },
            crate::JointCommandMsg { torque_nm: [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1e9], ..command },
            crate::JointCommandMsg { qd_ref_rad_s: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1e-9], ..command },
            crate::JointCommandMsg { twist_applied_tick: 3, ..command },
            crate::JointCommandMsg { reference_since_tick: 4, ..command },
        ] {
            assert_ne!(key.seal(&changed), seal);
        }
        let mode = crate::CellModeMsg {
            mode: crate::CellMode::SafeStop.into(),
            sequence: 2,
            fault: crate::Fault::TargetLost.into(),
            stamp_ns: 5,
            ..crate::CellModeMsg::default()
        };
        let seal = key.seal(&mode);
        assert_ne!(key.seal(&crate::CellModeMsg { mode: crate::CellMode::Servoing.into(), ..mode }), seal);
        assert_ne!(key.seal(&crate::CellModeMsg { sequence: 3, ..mode }), seal);
        assert_ne!(SealKey::random().expect("a key").seal(&mode), seal);
    }

    #[test]
    fn a_signed_twist_and_features_verify_under_their_key_only_and_not_once_changed() {
        let key = SealKey::random().expect("a key");
        let other = SealKey::random().expect("another key");
        let mut twist =
            crate::CameraTwistMsg { twist: [0.0, 0.0, 0.05, 0.0, 0.0, 0.0], ..Default::default() };
        sign_with(Some(&key), &mut twist);
        assert!(sealed_by(Some(&key), &twist));
        assert!(!sealed_by(Some(&other), &twist), "another key");
        assert!(!sealed_by(None, &twist), "no key: nothing is sealed");
        let changed = crate::CameraTwistMsg { twist: [0.0, 0.0, 0.06, 0.0, 0.0, 0.0], ..twist };
        assert!(!key.verifies(&changed), "a changed twist");
        let mut features = crate::FeaturesMsg { frame: 7, ..Default::default() };
        key.sign(&mut features);
        assert!(key.verifies(&features));
        assert!(!key.verifies(&crate::FeaturesMsg { features_px: [40.0; 8], ..features }), "moved features");
        sign_with(None, &mut features);
        assert_eq!(features.seal, 0, "a node without the key seals nothing");
    }
}
