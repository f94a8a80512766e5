//! CRC-32C (Castagnoli), the checksum carried by every frame.
//!
//! Reflected polynomial `0x82F63B78`, initial value and final XOR `0xFFFF_FFFF`
//! (the iSCSI / ext4 CRC). A 32-bit CRC detects every burst error of up to
//! 32 bits and lets a random corruption through with probability 2⁻³², which is
//! what "no wrong sample accepted" rests on.

/// The `crc` crate's CRC-32/ISCSI (= CRC-32C), table built at compile time.
const CASTAGNOLI: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);

/// CRC-32C of `bytes`.
///
/// ```
/// assert_eq!(rig_protocol::crc::crc32c(b"123456789"), 0xE306_9283);
/// ```
pub fn crc32c(bytes: &[u8]) -> u32 {
    CASTAGNOLI.checksum(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_value() {
        assert_eq!(crc32c(b"123456789"), 0xE306_9283);
        assert_eq!(crc32c(b""), 0);
    }
}
