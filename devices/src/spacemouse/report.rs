//! Pure parsing of 3Dconnexion HID reports and the table of known models.
//!
//! Report layout (as `hidapi` returns it: report id first, then the payload):
//! - **split** (older models, e.g. SpaceNavigator): id 1 = translation, id 2 = rotation,
//!   7 bytes each: `[id, x_lo, x_hi, y_lo, y_hi, z_lo, z_hi]`, little-endian `i16`;
//! - **combined** (newer models, e.g. SpaceMouse Wireless, Compact, Enterprise): one 13-byte
//!   id 1 report: translation x, y, z then rotation x, y, z, little-endian `i16`;
//! - **buttons**: id 3, then a little-endian bit mask (bit i = button i);
//!
//! Raw axes are the device's own HID frame: x to the right, y toward the operator, z down
//! (right-handed); rotation components are about those axes. [`super::AxisMap`] turns them
//! into the scene frame. The parser never panics: a short or unknown report is an error.

use thiserror::Error;

/// Report id of translation (split format) or translation + rotation (combined format).
pub const REPORT_MOTION: u8 = 1;
/// Report id of rotation in the split format.
pub const REPORT_ROTATION: u8 = 2;
/// Report id of the button mask.
pub const REPORT_BUTTONS: u8 = 3;
/// Logitech's vendor id, used by 3Dconnexion models made before 2011.
pub const VENDOR_LOGITECH: u16 = 0x046d;
/// 3Dconnexion's own vendor id.
pub const VENDOR_3DCONNEXION: u16 = 0x256f;
/// HID usage page "Generic Desktop".
pub const USAGE_PAGE_GENERIC_DESKTOP: u16 = 0x01;
/// HID usage "Multi-axis Controller" on the Generic Desktop page.
pub const USAGE_MULTI_AXIS: u16 = 0x08;

/// Which report layout a model uses for motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReportFormat {
    /// Translation in id 1 and rotation in id 2, 7 bytes each.
    Split,
    /// Translation and rotation together in one 13-byte id 1.
    Combined,
}

/// A known 3Dconnexion model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Model {
    /// USB vendor id.
    pub vendor_id: u16,
    /// USB product id.
    pub product_id: u16,
    /// Marketing name.
    pub name: &'static str,
    /// Motion report layout it normally sends (the parser accepts both regardless: it
    /// decides by report length).
    pub format: ReportFormat,
    /// Number of buttons.
    pub buttons: u32,
}

const fn m(
    vendor_id: u16,
    product_id: u16,
    name: &'static str,
    format: ReportFormat,
    buttons: u32,
) -> Model {
    Model {
        vendor_id,
        product_id,
        name,
        format,
        buttons,
    }
}

/// Models we recognise by vendor and product id (the spacenavd and 3Dconnexion device lists).
pub const KNOWN_MODELS: &[Model] = &[
    m(
        VENDOR_LOGITECH,
        0xc603,
        "SpaceMouse Plus XT",
        ReportFormat::Split,
        12,
    ),
    m(VENDOR_LOGITECH, 0xc605, "CadMan", ReportFormat::Split, 4),
    m(
        VENDOR_LOGITECH,
        0xc606,
        "SpaceMouse Classic",
        ReportFormat::Split,
        8,
    ),
    m(
        VENDOR_LOGITECH,
        0xc621,
        "SpaceBall 5000",
        ReportFormat::Split,
        12,
    ),
    m(
        VENDOR_LOGITECH,
        0xc623,
        "SpaceTraveler",
        ReportFormat::Split,
        8,
    ),
    m(
        VENDOR_LOGITECH,
        0xc625,
        "SpacePilot",
        ReportFormat::Split,
        21,
    ),
    m(
        VENDOR_LOGITECH,
        0xc626,
        "SpaceNavigator",
        ReportFormat::Split,
        2,
    ),
    m(
        VENDOR_LOGITECH,
        0xc627,
        "SpaceExplorer",
        ReportFormat::Split,
        15,
    ),
    m(
        VENDOR_LOGITECH,
        0xc628,
        "SpaceNavigator for Notebooks",
        ReportFormat::Split,
        2,
    ),
    m(
        VENDOR_LOGITECH,
        0xc629,
        "SpacePilot Pro",
        ReportFormat::Split,
        31,
    ),
    m(
        VENDOR_LOGITECH,
        0xc62b,
        "SpaceMouse Pro",
        ReportFormat::Split,
        15,
    ),
    m(
        VENDOR_3DCONNEXION,
        0xc62e,
        "SpaceMouse Wireless (cabled)",
        ReportFormat::Combined,
        2,
    ),
    m(
        VENDOR_3DCONNEXION,
        0xc62f,
        "SpaceMouse Wireless (receiver)",
        ReportFormat::Combined,
        2,
    ),
    m(
        VENDOR_3DCONNEXION,
        0xc631,
        "SpaceMouse Pro Wireless (cabled)",
        ReportFormat::Combined,
        15,
    ),
    m(
        VENDOR_3DCONNEXION,
        0xc632,
        "SpaceMouse Pro Wireless (receiver)",
        ReportFormat::Combined,
        15,
    ),
    m(
        VENDOR_3DCONNEXION,
        0xc633,
        "SpaceMouse Enterprise",
        ReportFormat::Combined,
        31,
    ),
    m(
        VENDOR_3DCONNEXION,
        0xc635,
        "SpaceMouse Compact",
        ReportFormat::Combined,
        2,
    ),
    m(
        VENDOR_3DCONNEXION,
        0xc636,
        "SpaceMouse Module",
        ReportFormat::Combined,
        2,
    ),
    m(
        VENDOR_3DCONNEXION,
        0xc652,
        "3Dconnexion Universal Receiver",
        ReportFormat::Combined,
        15,
    ),
];

/// The known model with these ids, if any.
pub fn known_model(vendor_id: u16, product_id: u16) -> Option<&'static Model> {
    KNOWN_MODELS
        .iter()
        .find(|m| m.vendor_id == vendor_id && m.product_id == product_id)
}

/// True for a HID interface we treat as a SpaceMouse: a known model, or any device of a
/// 3Dconnexion vendor id whose top-level collection is a multi-axis controller (usage page
/// 0x01, usage 0x08), so a model newer than our table still works.
pub fn is_spacemouse(vendor_id: u16, product_id: u16, usage_page: u16, usage: u16) -> bool {
    known_model(vendor_id, product_id).is_some()
        || ((vendor_id == VENDOR_LOGITECH || vendor_id == VENDOR_3DCONNEXION)
            && usage_page == USAGE_PAGE_GENERIC_DESKTOP
            && usage == USAGE_MULTI_AXIS)
}

/// One decoded input report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Report {
    /// Split format id 1: translation x, y, z (raw counts, HID frame).
    Translation([i16; 3]),
    /// Split format id 2: rotation about x, y, z (raw counts, HID frame).
    Rotation([i16; 3]),
    /// Combined format id 1: translation then rotation (raw counts, HID frame).
    Motion {
        /// Translation x, y, z.
        translation: [i16; 3],
        /// Rotation about x, y, z.
        rotation: [i16; 3],
    },
    /// Id 3: button mask, bit i = button i pressed.
    Buttons(u32),
}

/// Why a report could not be decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum ReportError {
    /// Zero bytes.
    #[error("empty HID report")]
    Empty,
    /// A motion report whose length is neither 7 (split) nor 13 (combined) bytes.
    #[error("HID report id {id} has {len} bytes; expected 7 (split) or 13 (combined)")]
    BadLength {
        /// Report id.
        id: u8,
        /// Bytes received, id included.
        len: usize,
    },
    /// A report id this parser does not use (battery, vendor-specific, …); not an error
    /// of the device, callers skip it.
    #[error("HID report id {0} is not a motion or button report")]
    Unhandled(u8),
}

fn i16_at(b: &[u8], i: usize) -> i16 {
    i16::from_le_bytes([b[i], b[i + 1]])
}

fn triple(b: &[u8], first: usize) -> [i16; 3] {
    [i16_at(b, first), i16_at(b, first + 2), i16_at(b, first + 4)]
}

/// Decodes one input report (`bytes[0]` is the report id). The motion layout is decided
/// by length, not by model, because some receivers switch layout with the paired device.
pub fn parse(bytes: &[u8]) -> Result<Report, ReportError> {
    let (&id, _) = bytes.split_first().ok_or(ReportError::Empty)?;
    let len = bytes.len();
    match id {
        REPORT_MOTION if len == 13 => Ok(Report::Motion {
            translation: triple(bytes, 1),
            rotation: triple(bytes, 7),
        }),
        REPORT_MOTION if len == 7 => Ok(Report::Translation(triple(bytes, 1))),
        REPORT_ROTATION if len == 7 => Ok(Report::Rotation(triple(bytes, 1))),
        REPORT_MOTION | REPORT_ROTATION => Err(ReportError::BadLength { id, len }),
        REPORT_BUTTONS => {
            // Up to 4 mask bytes; missing ones are zero (2-button models send 2 or 3).
            let mut mask = [0u8; 4];
            for (dst, src) in mask.iter_mut().zip(&bytes[1..]) {
                *dst = *src;
            }
            Ok(Report::Buttons(u32::from_le_bytes(mask)))
        }
        other => Err(ReportError::Unhandled(other)),
    }
}

/// The newest value of every axis and button, folded from reports (the device only reports
/// on change, so each field holds its last value).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RawAxes {
    /// Translation x, y, z in raw counts, HID frame.
    pub translation: [i16; 3],
    /// Rotation about x, y, z in raw counts, HID frame.
    pub rotation: [i16; 3],
    /// Button mask.
    pub buttons: u32,
}

impl RawAxes {
    /// Folds one report in.
    pub fn apply(&mut self, report: Report) {
        match report {
            Report::Translation(t) => self.translation = t,
            Report::Rotation(r) => self.rotation = r,
            Report::Motion {
                translation,
                rotation,
            } => {
                self.translation = translation;
                self.rotation = rotation;
            }
            Report::Buttons(b) => self.buttons = b,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_format_spacenavigator_bytes() {
        // SpaceNavigator (046d:c626): push right (+x 0x0120 = 288) and toward the user
        // (+y 5), then a twist (rz = -30 = 0xffe2).
        let t = [0x01, 0x20, 0x01, 0x05, 0x00, 0x00, 0x00];
        let r = [0x02, 0x00, 0x00, 0x00, 0x00, 0xe2, 0xff];
        assert_eq!(parse(&t), Ok(Report::Translation([288, 5, 0])));
        assert_eq!(parse(&r), Ok(Report::Rotation([0, 0, -30])));
        let mut axes = RawAxes::default();
        axes.apply(parse(&t).unwrap());
        axes.apply(parse(&r).unwrap());
        assert_eq!(axes.translation, [288, 5, 0]);
        assert_eq!(axes.rotation, [0, 0, -30]);
    }

    #[test]
    fn combined_format_spacemouse_wireless_bytes() {
        // SpaceMouse Wireless / Compact: one 13-byte id 1, extremes included.
        let b = [
            0x01, 0xa2, 0xfe, 0x5e, 0x01, 0x00, 0x80, 0xff, 0x7f, 0x01, 0x00, 0xff, 0xff,
        ];
        assert_eq!(
            parse(&b),
            Ok(Report::Motion {
                translation: [-350, 350, i16::MIN],
                rotation: [i16::MAX, 1, -1],
            })
        );
    }

    #[test]
    fn buttons_for_two_and_many_button_models() {
        // SpaceNavigator: 3 bytes, both buttons.
        assert_eq!(parse(&[0x03, 0x03, 0x00]), Ok(Report::Buttons(0b11)));
        // SpaceMouse Pro / Enterprise: longer masks; button 12 and 25.
        assert_eq!(
            parse(&[0x03, 0x00, 0x10, 0x00, 0x02, 0x00, 0x00]),
            Ok(Report::Buttons((1 << 12) | (1 << 25)))
        );
        // A bare id means no button.
        assert_eq!(parse(&[0x03]), Ok(Report::Buttons(0)));
    }

    #[test]
    fn bad_reports_are_errors_not_panics() {
        assert_eq!(parse(&[]), Err(ReportError::Empty));
        assert_eq!(
            parse(&[0x01, 0x00, 0x01]),
            Err(ReportError::BadLength { id: 1, len: 3 })
        );
        assert_eq!(
            parse(&[0x02; 13]),
            Err(ReportError::BadLength { id: 2, len: 13 })
        );
        // Battery report of wireless models.
        assert_eq!(parse(&[0x17, 0x64]), Err(ReportError::Unhandled(0x17)));
        // Every length 0..64 of every id decodes or errors, never panics.
        for id in 0..=255u8 {
            for len in 0..64 {
                let mut v = vec![0x5a; len];
                if let Some(first) = v.first_mut() {
                    *first = id;
                }
                let _ = parse(&v);
            }
        }
    }

    #[test]
    fn model_table_and_usage_fallback() {
        let nav = known_model(0x046d, 0xc626).expect("SpaceNavigator");
        assert_eq!(nav.format, ReportFormat::Split);
        let compact = known_model(0x256f, 0xc635).expect("SpaceMouse Compact");
        assert_eq!(compact.format, ReportFormat::Combined);
        assert!(is_spacemouse(0x046d, 0xc626, 0, 0));
        // Unknown product of 3Dconnexion with a multi-axis collection: accepted.
        assert!(is_spacemouse(0x256f, 0xc6ff, 0x01, 0x08));
        // Unknown product, keyboard collection: rejected.
        assert!(!is_spacemouse(0x256f, 0xc6ff, 0x01, 0x06));
        // Another vendor's multi-axis controller: rejected.
        assert!(!is_spacemouse(0x1234, 0x5678, 0x01, 0x08));
        // No duplicate ids in the table.
        for (i, a) in KNOWN_MODELS.iter().enumerate() {
            for b in &KNOWN_MODELS[i + 1..] {
                assert!((a.vendor_id, a.product_id) != (b.vendor_id, b.product_id));
            }
        }
    }
}
