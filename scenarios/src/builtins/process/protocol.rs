//! The messages of the process-localizer protocol (`docs/protocol.md`, one JSON Schema per
//! message in `docs/protocol/`): what Atrium writes to the process's stdin, one JSON object
//! per line, and the answers it reads from the process's stdout.

use atrium_robots::{Mount3, Pose2, Reading};
use nalgebra::Matrix3;
use serde::Serialize;
use serde_json::{json, Map, Value};

/// The protocol versions Atrium speaks, oldest first.
pub const PROTOCOLS: &[u64] = &[1];

/// Every reading kind the protocol carries, in the order the documentation lists them.
pub const READING_KINDS: &[&str] = &[
    "laser",
    "wifi",
    "landmarks",
    "depth",
    "intensity",
    "disparity",
];

fn pose3(p: &Pose2) -> [f64; 3] {
    [p.x, p.y, p.theta]
}

/// A message to the process after the hello (the hello is built by `hello`).
#[derive(Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Message<'a> {
    Odometry {
        t: f64,
        from: [f64; 3],
        to: [f64; 3],
    },
    Laser {
        t: f64,
        sensor: &'a str,
        mount: [f64; 3],
        angle_min: f64,
        angle_increment: f64,
        range_min: f64,
        range_max: f64,
        ranges: &'a [f64],
    },
    Wifi {
        t: f64,
        sensor: &'a str,
        readings: Vec<WifiAp<'a>>,
    },
    Landmarks {
        t: f64,
        sensor: &'a str,
        mount: [f64; 3],
        detections: &'a [atrium_robots::LandmarkDetection],
    },
    Depth {
        t: f64,
        sensor: &'a str,
        mount: &'a Mount3,
        width: usize,
        height: usize,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        depth: &'a [f32],
    },
    Intensity {
        t: f64,
        sensor: &'a str,
        mount: &'a Mount3,
        width: usize,
        height: usize,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        pixels: &'a [f32],
    },
    Disparity {
        t: f64,
        sensor: &'a str,
        width: usize,
        height: usize,
        fx: f64,
        baseline: f64,
        /// `null` where stereo found no match (NaN in Atrium).
        disparity: Vec<Option<f32>>,
    },
    Bye,
}

#[derive(Serialize)]
pub struct WifiAp<'a> {
    ap: &'a str,
    channel: u32,
    rssi: f64,
}

impl<'a> Message<'a> {
    pub fn odometry(t: f64, from: &Pose2, to: &Pose2) -> Self {
        Message::Odometry {
            t,
            from: pose3(from),
            to: pose3(to),
        }
    }

    /// The message carrying `reading` and its kind; `None` for odometry (sent as deltas)
    /// and for kinds the protocol does not carry.
    pub fn reading(reading: &'a Reading) -> Option<(&'static str, Self)> {
        Some(match reading {
            Reading::Laser(s) => (
                "laser",
                Message::Laser {
                    t: s.stamp,
                    sensor: &s.sensor,
                    mount: pose3(&s.mount),
                    angle_min: s.angle_min,
                    angle_increment: s.angle_increment,
                    range_min: s.range_min,
                    range_max: s.range_max,
                    ranges: &s.ranges,
                },
            ),
            Reading::Wifi(w) => (
                "wifi",
                Message::Wifi {
                    t: w.stamp,
                    sensor: &w.sensor,
                    readings: w
                        .readings
                        .iter()
                        .map(|r| WifiAp {
                            ap: &r.ap,
                            channel: r.channel,
                            rssi: r.rssi_dbm,
                        })
                        .collect(),
                },
            ),
            Reading::Landmarks(l) => (
                "landmarks",
                Message::Landmarks {
                    t: l.stamp,
                    sensor: &l.sensor,
                    mount: pose3(&l.mount),
                    detections: &l.detections,
                },
            ),
            Reading::Depth(d) => (
                "depth",
                Message::Depth {
                    t: d.stamp,
                    sensor: &d.sensor,
                    mount: &d.mount,
                    width: d.width,
                    height: d.height,
                    fx: d.fx,
                    fy: d.fy,
                    cx: d.cx,
                    cy: d.cy,
                    depth: &d.depth,
                },
            ),
            Reading::Intensity(i) => (
                "intensity",
                Message::Intensity {
                    t: i.stamp,
                    sensor: &i.sensor,
                    mount: &i.mount,
                    width: i.width,
                    height: i.height,
                    fx: i.fx,
                    fy: i.fy,
                    cx: i.cx,
                    cy: i.cy,
                    pixels: &i.pixels,
                },
            ),
            Reading::Disparity(d) => (
                "disparity",
                Message::Disparity {
                    t: d.stamp,
                    sensor: &d.sensor,
                    width: d.width,
                    height: d.height,
                    fx: d.fx,
                    baseline: d.baseline,
                    disparity: d
                        .disparity
                        .iter()
                        .map(|v| v.is_finite().then_some(*v))
                        .collect(),
                },
            ),
            _ => return None,
        })
    }

    /// One line of JSON (no newline). Non-finite numbers become `null` (serde_json's rule);
    /// the readings Atrium produces hold none but the disparity gaps, sent as `null`.
    pub fn to_line(&self) -> Vec<u8> {
        serde_json::to_vec(self).unwrap_or_else(|e| {
            // Serialising these plain structs cannot fail; keep the protocol alive anyway.
            serde_json::to_vec(&json!({"type": "invalid", "error": e.to_string()}))
                .unwrap_or_default()
        })
    }
}

/// What the process answered.
#[derive(Debug, Clone, PartialEq)]
pub enum Answer {
    Hello {
        protocol: u64,
        /// The reading kinds it wants (None: every kind).
        subscribe: Option<Vec<String>>,
        /// Its belief before any reading, if it gave one.
        estimate: Option<(Pose2, Option<Matrix3<f64>>)>,
    },
    Estimate {
        t: Option<f64>,
        pose: Pose2,
        covariance: Option<Matrix3<f64>>,
    },
    Error(String),
}

/// At most `max` characters of `line`, quoted, for error messages.
pub fn quote(line: &[u8], max: usize) -> String {
    let text = String::from_utf8_lossy(line);
    let mut out: String = text.chars().take(max).collect();
    if text.chars().count() > max {
        out.push_str(" ...");
    }
    format!("{out:?}")
}

/// Parses one answer line. The error says what is wrong and quotes the line (truncated).
pub fn parse_answer(line: &[u8]) -> Result<Answer, String> {
    let v: Value = match serde_json::from_slice(line) {
        Ok(v) => v,
        Err(e) => {
            let text = String::from_utf8_lossy(line);
            let non_finite = ["NaN", "Infinity"].iter().any(|w| text.contains(w));
            return Err(if non_finite {
                format!(
                    "the answer holds NaN or Infinity (JSON has no such numbers; an estimate \
                     must be finite): {}",
                    quote(line, 200)
                )
            } else {
                format!(
                    "malformed JSON ({e}): {} (stdout carries answers only, one JSON line per \
                     message; print debugging output to stderr, which Atrium keeps in the log)",
                    quote(line, 200)
                )
            });
        }
    };
    let bad = |what: String| format!("{what}: {}", quote(line, 200));
    let Some(obj) = v.as_object() else {
        return Err(bad("the answer is not a JSON object".into()));
    };
    let kind = obj.get("type").and_then(Value::as_str).unwrap_or_default();
    match kind {
        "hello" => {
            let protocol = obj
                .get("protocol")
                .and_then(Value::as_u64)
                .ok_or_else(|| bad("the hello answer has no integer \"protocol\"".into()))?;
            let subscribe = match obj.get("subscribe") {
                None | Some(Value::Null) => None,
                Some(Value::Array(items)) => Some(
                    items
                        .iter()
                        .map(|i| {
                            i.as_str().map(str::to_string).ok_or_else(|| {
                                bad("\"subscribe\" must be a list of reading kinds".into())
                            })
                        })
                        .collect::<Result<Vec<_>, _>>()?,
                ),
                Some(_) => return Err(bad("\"subscribe\" must be a list of reading kinds".into())),
            };
            let estimate = match obj.get("pose") {
                None | Some(Value::Null) => None,
                Some(p) => Some((pose(p).map_err(&bad)?, covariance(obj).map_err(&bad)?)),
            };
            Ok(Answer::Hello {
                protocol,
                subscribe,
                estimate,
            })
        }
        "estimate" => {
            let t = match obj.get("t") {
                None | Some(Value::Null) => None,
                Some(t) => Some(
                    t.as_f64()
                        .ok_or_else(|| bad("\"t\" must be a number".into()))?,
                ),
            };
            let p = obj
                .get("pose")
                .ok_or_else(|| bad("the estimate has no \"pose\"".into()))?;
            Ok(Answer::Estimate {
                t,
                pose: pose(p).map_err(&bad)?,
                covariance: covariance(obj).map_err(&bad)?,
            })
        }
        "error" => Ok(Answer::Error(
            obj.get("message")
                .map(|m| m.as_str().map_or_else(|| m.to_string(), str::to_string))
                .unwrap_or_else(|| "(no message)".into()),
        )),
        "" => Err(bad("the answer has no \"type\"".into())),
        other => Err(bad(format!(
            "unexpected answer type {other:?} (expected \"estimate\" or \"error\")"
        ))),
    }
}

fn numbers(v: &Value, n: usize, what: &str) -> Result<Vec<f64>, String> {
    let items = v
        .as_array()
        .filter(|a| a.len() == n)
        .ok_or_else(|| format!("\"{what}\" must be a list of {n} numbers"))?;
    items
        .iter()
        .enumerate()
        .map(|(i, x)| match x.as_f64() {
            Some(f) if f.is_finite() => Ok(f),
            _ => Err(format!("{what}[{i}] is {x}, not a finite number")),
        })
        .collect()
}

fn pose(v: &Value) -> Result<Pose2, String> {
    let p = numbers(v, 3, "pose")?;
    Ok(Pose2::new(p[0], p[1], atrium_robots::normalize_angle(p[2])))
}

fn covariance(obj: &Map<String, Value>) -> Result<Option<Matrix3<f64>>, String> {
    match obj.get("covariance") {
        None | Some(Value::Null) => Ok(None),
        Some(c) => {
            let c = numbers(c, 9, "covariance")?;
            // A negative variance is no covariance (NEES would be undefined, silently).
            for (i, name) in [(0, "x"), (4, "y"), (8, "theta")] {
                if c[i] < 0.0 {
                    return Err(format!(
                        "covariance[{i}] (the variance of {name}) is negative ({}): a \
                         covariance's diagonal must be >= 0",
                        c[i]
                    ));
                }
            }
            Ok(Some(Matrix3::from_row_slice(&c)))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_estimates_and_names_what_is_wrong() {
        let a = parse_answer(br#"{"type":"estimate","t":1.5,"pose":[1,2,7]}"#).unwrap();
        let Answer::Estimate {
            t,
            pose,
            covariance,
        } = a
        else {
            panic!("{a:?}")
        };
        assert_eq!(t, Some(1.5));
        assert!((pose.theta - (7.0 - 2.0 * std::f64::consts::PI)).abs() < 1e-12);
        assert!(covariance.is_none());
        let a =
            parse_answer(br#"{"type":"estimate","pose":[0,0,0],"covariance":[1,0,0,0,2,0,0,0,3]}"#)
                .unwrap();
        let Answer::Estimate { covariance, .. } = a else {
            panic!()
        };
        assert_eq!(covariance.unwrap()[(1, 1)], 2.0);

        let e = parse_answer(b"hello there").unwrap_err();
        assert!(
            e.contains("malformed JSON") && e.contains("hello there"),
            "{e}"
        );
        assert!(e.contains("print debugging output to stderr"), "{e}");
        let e = parse_answer(
            br#"{"type":"estimate","pose":[0,0,0],"covariance":[1,0,0,0,-2,0,0,0,3]}"#,
        )
        .unwrap_err();
        assert!(
            e.contains("covariance[4] (the variance of y) is negative"),
            "{e}"
        );
        let e = parse_answer(br#"{"type":"estimate","pose":[NaN,0,0]}"#).unwrap_err();
        assert!(e.contains("NaN"), "{e}");
        let e = parse_answer(br#"{"type":"estimate","pose":[null,0,0]}"#).unwrap_err();
        assert!(e.contains("pose[0] is null"), "{e}");
        let e = parse_answer(br#"{"type":"estimate","pose":[1e999,0,0]}"#).unwrap_err();
        assert!(e.contains("pose"), "{e}");
        let e = parse_answer(br#"{"type":"estimate","pose":[0,0]}"#).unwrap_err();
        assert!(e.contains("3 numbers"), "{e}");
        let e =
            parse_answer(br#"{"type":"estimate","pose":[0,0,0],"covariance":[1]}"#).unwrap_err();
        assert!(e.contains("9 numbers"), "{e}");
        let e = parse_answer(br#"{"type":"wat"}"#).unwrap_err();
        assert!(e.contains("unexpected answer type"), "{e}");
        let e = parse_answer(&[b'x'; 1000]).unwrap_err();
        assert!(e.len() < 400, "{e}");
        assert_eq!(
            parse_answer(br#"{"type":"error","message":"no map"}"#).unwrap(),
            Answer::Error("no map".into())
        );
    }

    #[test]
    fn parses_the_hello_answer() {
        let a = parse_answer(br#"{"type":"hello","protocol":1,"subscribe":["laser"]}"#).unwrap();
        assert_eq!(
            a,
            Answer::Hello {
                protocol: 1,
                subscribe: Some(vec!["laser".into()]),
                estimate: None
            }
        );
        assert!(parse_answer(br#"{"type":"hello"}"#).is_err());
        assert!(parse_answer(br#"{"type":"hello","protocol":1,"subscribe":"laser"}"#).is_err());
    }

    #[test]
    fn disparity_gaps_are_null() {
        let d = Reading::Disparity(atrium_robots::DisparityImage {
            stamp: 1.0,
            sensor: "stereo".into(),
            width: 2,
            height: 1,
            fx: 100.0,
            baseline: 0.1,
            disparity: vec![f32::NAN, 3.0],
        });
        let (kind, m) = Message::reading(&d).unwrap();
        assert_eq!(kind, "disparity");
        let v: Value = serde_json::from_slice(&m.to_line()).unwrap();
        assert_eq!(v["disparity"], json!([null, 3.0]));
        assert_eq!(v["type"], "disparity");
    }
}
