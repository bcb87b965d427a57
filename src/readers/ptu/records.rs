//! PTU time-tagged records (32 bits each, little-endian), decoded into events on the
//! global clock (sync periods since the start): photons with their channel and start-stop
//! time (`dtime`, in bins of `MeasDesc_Resolution`), markers (line and frame clocks of a
//! scanner) and overflows (the clock's wrap). The layouts are PicoQuant's, the same as
//! `ptufile` decodes them:
//!
//! | record type | code | nsync bits | dtime bits | channel | overflow adds |
//! |---|---|---|---|---|---|
//! | PicoHarp T3 | 0x00010303 | 16 | 12 | 4 bits, 1-4 (15: special) | 65536 |
//! | HydraHarp T3 (v1) | 0x00010304 | 10 | 15 | 6 bits, special bit 31 | 1024 |
//! | HydraHarp 2, TimeHarp 260 N/P, MultiHarp (generic) T3 | 0x01010304, 0x00010305, 0x00010306, 0x00010307 | 10 | 15 | 6 bits, special bit 31 | 1024 per count in nsync (at least one) |
//!
//! T2 records (absolute time tags without a start-stop time) are recognised and named, not
//! decoded.

/// One decoded record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event {
    /// A photon: its channel (0-based; PicoHarp's invalid channel codes give 4, which no
    /// image counts, as in `ptufile`) and its start-stop time in bins.
    Photon { channel: u32, dtime: u32 },
    /// Marker bits (bit 0 is marker 1).
    Marker(u32),
    /// The clock wrapped, or a record that carries no event.
    None,
}

/// The record types femto decodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RecordType {
    PicoHarpT3,
    HydraHarpV1T3,
    /// HydraHarp 2, TimeHarp 260 N and P, MultiHarp and other generic T3 records.
    GenericT3,
}

impl RecordType {
    /// The type of a `TTResultFormat_TTTRRecType` code; `Err` names a T2 or unknown type.
    pub fn from_code(code: i64) -> Result<RecordType, String> {
        Ok(match code {
            0x0001_0303 => RecordType::PicoHarpT3,
            0x0001_0304 => RecordType::HydraHarpV1T3,
            0x0101_0304 | 0x0001_0305 | 0x0001_0306 | 0x0001_0307 => RecordType::GenericT3,
            0x0001_0203 => return Err("PicoHarp T2".into()),
            0x0001_0204 | 0x0101_0204 => return Err("HydraHarp T2".into()),
            0x0001_0205 | 0x0001_0206 => return Err("TimeHarp 260 T2".into()),
            0x0001_0207 => return Err("MultiHarp (generic) T2".into()),
            other => return Err(format!("unknown record type 0x{other:08X}")),
        })
    }

    /// Its name for messages and provenance.
    pub fn name(self) -> &'static str {
        match self {
            RecordType::PicoHarpT3 => "PicoHarp T3",
            RecordType::HydraHarpV1T3 => "HydraHarp T3 (v1)",
            RecordType::GenericT3 => "HydraHarp 2 / TimeHarp 260 / MultiHarp T3",
        }
    }

    /// The number of start-stop bins the records can hold.
    pub fn max_bins(self) -> u32 {
        match self {
            RecordType::PicoHarpT3 => 4096,
            _ => 32768,
        }
    }

    /// The number of channels the records can name.
    pub fn max_channels(self) -> u32 {
        match self {
            RecordType::PicoHarpT3 => 4,
            _ => 64,
        }
    }
}

/// Decodes records in order, keeping the clock's overflow.
#[derive(Clone, Debug)]
pub struct Decoder {
    kind: RecordType,
    overflow: u64,
}

impl Decoder {
    pub fn new(kind: RecordType) -> Decoder {
        Decoder { kind, overflow: 0 }
    }

    /// The record's event and its time on the global clock (sync periods).
    #[inline]
    pub fn next(&mut self, r: u32) -> (u64, Event) {
        match self.kind {
            RecordType::PicoHarpT3 => {
                let nsync = r & 0xFFFF;
                let dtime = (r >> 16) & 0xFFF;
                let chan = (r >> 28) & 0xF;
                let event = if chan != 0xF {
                    let channel = if (1..5).contains(&chan) { chan - 1 } else { 4 };
                    Event::Photon { channel, dtime }
                } else if dtime == 0 {
                    self.overflow += 65536;
                    Event::None
                } else {
                    Event::Marker(dtime)
                };
                (self.overflow + u64::from(nsync), event)
            }
            RecordType::HydraHarpV1T3 | RecordType::GenericT3 => {
                let nsync = r & 0x3FF;
                let dtime = (r >> 10) & 0x7FFF;
                let chan = (r >> 25) & 0x3F;
                let event = if r >> 31 == 0 {
                    Event::Photon {
                        channel: chan,
                        dtime,
                    }
                } else if chan == 0x3F {
                    self.overflow += match self.kind {
                        RecordType::HydraHarpV1T3 => 1024,
                        _ => 1024 * u64::from(nsync.max(1)),
                    };
                    Event::None
                } else if (1..16).contains(&chan) {
                    Event::Marker(chan)
                } else {
                    Event::None
                };
                (self.overflow + u64::from(nsync), event)
            }
        }
    }
}

/// Encoders for tests: records built from the format definition above.
#[cfg(test)]
pub mod encode {
    /// A PicoHarp T3 photon (channel 0-3).
    pub fn pt3_photon(nsync: u32, dtime: u32, channel: u32) -> u32 {
        ((channel + 1) << 28) | (dtime << 16) | nsync
    }
    /// A PicoHarp T3 marker (bits 1-15).
    pub fn pt3_marker(nsync: u32, bits: u32) -> u32 {
        (0xF << 28) | (bits << 16) | nsync
    }
    /// A PicoHarp T3 overflow (adds 65536).
    pub fn pt3_overflow() -> u32 {
        0xF << 28
    }
    /// A HydraHarp 2 / generic T3 photon.
    pub fn ht3_photon(nsync: u32, dtime: u32, channel: u32) -> u32 {
        (channel << 25) | (dtime << 10) | nsync
    }
    /// A HydraHarp 2 / generic T3 marker.
    pub fn ht3_marker(nsync: u32, bits: u32) -> u32 {
        (1 << 31) | (bits << 25) | nsync
    }
    /// A HydraHarp 2 / generic T3 overflow of `count` wraps of 1024.
    pub fn ht3_overflow(count: u32) -> u32 {
        (1 << 31) | (0x3F << 25) | count
    }
}

#[cfg(test)]
mod tests {
    use super::encode::*;
    use super::*;

    #[test]
    fn records_decode_as_the_format_defines_them() {
        let mut d = Decoder::new(RecordType::PicoHarpT3);
        assert_eq!(
            d.next(pt3_photon(5, 100, 2)),
            (
                5,
                Event::Photon {
                    channel: 2,
                    dtime: 100
                }
            )
        );
        assert_eq!(d.next(pt3_overflow()).1, Event::None);
        assert_eq!(d.next(pt3_marker(7, 4)), (65536 + 7, Event::Marker(4)));
        let mut h = Decoder::new(RecordType::GenericT3);
        assert_eq!(
            h.next(ht3_photon(3, 20000, 40)),
            (
                3,
                Event::Photon {
                    channel: 40,
                    dtime: 20000
                }
            )
        );
        h.next(ht3_overflow(3));
        assert_eq!(h.next(ht3_marker(9, 2)), (3 * 1024 + 9, Event::Marker(2)));
        let mut v1 = Decoder::new(RecordType::HydraHarpV1T3);
        v1.next(ht3_overflow(3));
        assert_eq!(v1.next(ht3_marker(9, 1)).0, 1024 + 9);
        assert!(RecordType::from_code(0x0001_0203)
            .unwrap_err()
            .contains("T2"));
        assert_eq!(
            RecordType::from_code(0x0001_0307),
            Ok(RecordType::GenericT3)
        );
    }
}
