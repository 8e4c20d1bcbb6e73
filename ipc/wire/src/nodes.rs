//! The answer to `NODES` (`command::NODES`): what the nodes on the bus told about themselves
//! at boot, one line per node, written by `hob-rt` and read by `hob commission`, here once:
//!
//! ```text
//! AXIS NODE VENDOR PRODUCT REVISION SERIAL VELOCITY_KP VELOCITY_TI_MS POSITION_KV
//! B 1 0x00000B0B 0x00020192 0x00010000 0x00001001 7.5398 1.5915 376.99
//! X 2 0x00000B0B 0x00020192 0x00010000 0x00001002 - - -
//! IO 4 0x00000B0B 0x00030191 0x00010000 0x00001004 - - -
//! ```
//!
//! AXIS is `B`, `X`, `Y`, `IO` (or `?`), NODE the node-ID (decimal), then the identity
//! (CiA 301 0x1018 sub 1 to 4, hex), then the drive's loop gains as read at boot (CiA 402
//! 0x60F9:01, 0x60F9:02, 0x60FB:01): the velocity loop's gain, N m s/rad at the motor, its
//! integral time, ms, the position loop's gain, 1/s; `-` each when unknown (not read: the
//! other nodes; not served: a drive without those objects). A line of the six identity
//! words alone (a `hob-rt` before the gains) reads as gains unknown.

/// A drive as it names itself: vendor id, product code, serial number (CiA 301 0x1018).
pub type DriveIdentity = (u32, u32, u32);

/// A drive's loop gains (in SI-derived units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveGains {
    pub velocity_kp_nm_s_per_rad: f64,
    pub velocity_integral_time_ms: f64,
    pub position_kv_per_s: f64,
}

/// One node's line.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeLine {
    /// `B`, `X`, `Y`, `IO` or `?`.
    pub axis: String,
    pub node: u8,
    pub vendor_id: u32,
    pub product_code: u32,
    pub revision: u32,
    pub serial: u32,
    pub gains: Option<DriveGains>,
}

impl NodeLine {
    pub fn identity(&self) -> DriveIdentity {
        (self.vendor_id, self.product_code, self.serial)
    }
}

/// The answer's text: one line per node, each ended by a newline.
pub fn write(lines: &[NodeLine]) -> String {
    lines
        .iter()
        .map(|l| {
            let gains = match l.gains {
                Some(g) => format!(
                    "{} {} {}",
                    g.velocity_kp_nm_s_per_rad, g.velocity_integral_time_ms, g.position_kv_per_s
                ),
                None => "- - -".to_string(),
            };
            format!(
                "{} {} 0x{:08X} 0x{:08X} 0x{:08X} 0x{:08X} {gains}\n",
                l.axis, l.node, l.vendor_id, l.product_code, l.revision, l.serial
            )
        })
        .collect()
}

/// The lines of an answer; an error names the line that is not one and why.
pub fn parse(text: &str) -> Result<Vec<NodeLine>, String> {
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .enumerate()
        .map(|(n, l)| parse_line(l).map_err(|why| format!("NODES line {}: {why}: {l:?}", n + 1)))
        .collect()
}

fn parse_line(line: &str) -> Result<NodeLine, String> {
    let w: Vec<&str> = line.split_whitespace().collect();
    let hex = |i: usize, what: &str| {
        u32::from_str_radix(w[i].trim_start_matches("0x"), 16).map_err(|_| format!("{what} is no hex number"))
    };
    let (identity, gains) = match w.len() {
        6 => (&w[..6], None),
        9 => (&w[..6], Some(&w[6..])),
        n => return Err(format!("{n} words, not 6 or 9")),
    };
    let gains = match gains {
        None | Some(["-", "-", "-"]) => None,
        Some(g) => {
            let num = |i: usize, what: &str| {
                g[i].parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| format!("the {what} is no number"))
            };
            Some(DriveGains {
                velocity_kp_nm_s_per_rad: num(0, "velocity gain")?,
                velocity_integral_time_ms: num(1, "velocity integral time")?,
                position_kv_per_s: num(2, "position gain")?,
            })
        }
    };
    Ok(NodeLine {
        axis: identity[0].to_string(),
        node: identity[1]
            .parse()
            .map_err(|_| "the node-ID is no number 0..=255".to_string())?,
        vendor_id: hex(2, "the vendor id")?,
        product_code: hex(3, "the product code")?,
        revision: hex(4, "the revision")?,
        serial: hex(5, "the serial")?,
        gains,
    })
}

/// The table drive's line (`B`), if the answer has one that reads.
fn table_line(nodes_text: &str) -> Option<NodeLine> {
    let line = nodes_text.lines().find(|l| l.starts_with("B "))?;
    parse_line(line).ok()
}

/// The table drive's identity from the answer.
pub fn table_drive(nodes_text: &str) -> Option<DriveIdentity> {
    table_line(nodes_text).map(|l| l.identity())
}

/// The table drive's loop gains from the answer (None: unknown, or no table drive).
pub fn table_drive_gains(nodes_text: &str) -> Option<DriveGains> {
    table_line(nodes_text)?.gains
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn gains() -> impl Strategy<Value = Option<DriveGains>> {
        proptest::option::of(
            (1e-4f64..1e3, 1e-2f64..1e4, 1e-3f64..1e4).prop_map(|(kp, ti, kv)| DriveGains {
                velocity_kp_nm_s_per_rad: kp,
                velocity_integral_time_ms: ti,
                position_kv_per_s: kv,
            }),
        )
    }

    fn line() -> impl Strategy<Value = NodeLine> {
        (
            prop::sample::select(vec!["B", "X", "Y", "IO", "?"]),
            any::<u8>(),
            any::<(u32, u32, u32, u32)>(),
            gains(),
        )
            .prop_map(|(axis, node, (v, p, r, s), gains)| NodeLine {
                axis: axis.to_string(),
                node,
                vendor_id: v,
                product_code: p,
                revision: r,
                serial: s,
                gains,
            })
    }

    proptest! {
        #[test]
        fn every_parse_of_a_write_is_the_identity(lines in prop::collection::vec(line(), 0..6)) {
            let text = write(&lines);
            prop_assert_eq!(parse(&text), Ok(lines.clone()));
            let b = lines.iter().find(|l| l.axis == "B");
            prop_assert_eq!(table_drive(&text), b.map(NodeLine::identity));
            prop_assert_eq!(table_drive_gains(&text), b.and_then(|l| l.gains));
        }
    }

    #[test]
    fn the_table_drive_is_read_from_its_line() {
        let text = "B 1 0x00000B0B 0x00020192 0x00010000 0x00001001 1.91 8.6 100.5\n\
                    X 2 0x00000B0B 0x00020192 0x00010000 0x00001002 - - -\n";
        assert_eq!(table_drive(text), Some((0x0B0B, 0x0002_0192, 0x1001)));
        assert_eq!(
            table_drive_gains(text),
            Some(DriveGains {
                velocity_kp_nm_s_per_rad: 1.91,
                velocity_integral_time_ms: 8.6,
                position_kv_per_s: 100.5,
            })
        );
        // A hob-rt before the gains: six words, the gains unknown.
        let old = "B 1 0x00000B0B 0x00020192 0x00010000 0x00001001\n";
        assert_eq!(table_drive(old), Some((0x0B0B, 0x0002_0192, 0x1001)));
        assert_eq!(table_drive_gains(old), None);
        assert_eq!(table_drive("X 2 0x0 0x0 0x0 0x0\n"), None);
    }

    #[test]
    fn a_line_that_is_none_is_refused_naming_it() {
        for bad in [
            "B 1 0x00000B0B 0x00020192 0x00010000\n",
            "B 1 0xZZ 0x00020192 0x00010000 0x00001001 - - -\n",
            "B 300 0x0 0x0 0x0 0x0\n",
            "B 1 0x0 0x0 0x0 0x0 1.0 - -\n",
            "B 1 0x0 0x0 0x0 0x0 1.0 2.0 inf\n",
        ] {
            let e = parse(bad).unwrap_err();
            assert!(e.starts_with("NODES line 1: "), "{e}");
        }
    }
}
