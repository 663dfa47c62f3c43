//! Output files are written under a temporary name and renamed when complete, so an
//! interrupted run never leaves a half-written file under the final name.

use std::path::{Path, PathBuf};

pub use crate::atomic::{
    end_child_groups, remove_unfinished, write_atomic, ChildGroup, Unfinished,
};

/// Checks, before a long run, that `dir` can be written: it is a folder (or can be created
/// as one: its nearest existing ancestor is a folder) and a file can be created in it.
/// Creates nothing that is not removed again, so a refused run leaves no trace.
pub fn check_writable_dir(dir: &Path, what: &str) -> Result<(), String> {
    let mut existing = dir;
    while !existing.exists() {
        match existing.parent() {
            Some(p) if !p.as_os_str().is_empty() => existing = p,
            _ => {
                existing = Path::new(".");
                break;
            }
        }
    }
    if !existing.is_dir() {
        return Err(format!(
            "{what}: {}: {} is not a folder",
            dir.display(),
            existing.display()
        ));
    }
    let probe = existing.join(format!(".atrium-write-probe.{}", std::process::id()));
    match std::fs::File::create(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => Err(format!(
            "{what}: {}: cannot write in {}: {e}",
            dir.display(),
            existing.display()
        )),
    }
}

/// [`check_writable_dir`] for the folder an output file `path` goes into; `path` itself must
/// not be a folder.
pub fn check_writable_file(path: &Path, what: &str) -> Result<(), String> {
    if path.is_dir() {
        return Err(format!(
            "{what}: {} is a folder, not a file",
            path.display()
        ));
    }
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
    check_writable_dir(parent.unwrap_or(Path::new(".")), what)
}

/// Writes a run's files into `dir`: TUM trajectories (`ground_truth.tum`, `<localizer>.tum`),
/// `metrics.json` (the `--json` document) and a picture per localizer
/// (`trajectory_<localizer>.svg` / `.png`), plus, for EKF-SLAM localizers, the covariance
/// pictures of `slam_plot` (`slam_<localizer>_<mode>_<frame>.svg` / `.png`), and the text a
/// localizer kept with the run (`log_<localizer>.txt`: a process localizer's stderr). Returns
/// the paths written.
pub fn write_run(
    dir: &Path,
    world: &atrium_worlds::World,
    run: &crate::runner::RunResult,
) -> Result<Vec<std::path::PathBuf>, String> {
    std::fs::create_dir_all(dir)
        .map_err(|e| format!("{}: cannot create folder: {e}", dir.display()))?;
    let mut written = Vec::new();
    let put = |written: &mut Vec<PathBuf>, name: String, bytes: Vec<u8>| -> Result<(), String> {
        let p = dir.join(name);
        write_atomic(&p, &bytes).map_err(|e| format!("{}: cannot write file: {e}", p.display()))?;
        written.push(p);
        Ok(())
    };
    // Stamped in the recording's own time, so other tools line them up with the log.
    let offset = run.time_offset_s();
    let tum = |poses: &[(f64, atrium_robots::Pose2)]| {
        let shifted: Vec<(f64, atrium_robots::Pose2)> =
            poses.iter().map(|(t, p)| (t + offset, *p)).collect();
        atrium_formats::tum::to_tum(&shifted).into_bytes()
    };
    let truth_name = if run.log.is_some() {
        "reference.tum"
    } else {
        "ground_truth.tum"
    };
    put(&mut written, truth_name.into(), tum(&run.ground_truth))?;
    for l in &run.localizers {
        put(&mut written, format!("{}.tum", l.name), tum(&l.trajectory))?;
        let fig = crate::plot::trajectory_figure(world, run, l)
            .map_err(|e| format!("trajectory_{}: {e}", l.name))?;
        write_figure(&mut written, dir, &format!("trajectory_{}", l.name), &fig)?;
        if let Some(log) = &l.log {
            put(
                &mut written,
                format!("log_{}.txt", l.name),
                log.clone().into_bytes(),
            )?;
        }
        if let Some(slam) = &l.slam {
            let figs = crate::slam_plot::figures(world, run, l, slam)
                .map_err(|e| format!("slam_{}: {e}", l.name))?;
            for (stem, fig) in figs {
                write_figure(&mut written, dir, &stem, &fig)?;
            }
        }
    }
    let json =
        serde_json::to_string_pretty(&crate::report::to_json(run)).map_err(|e| e.to_string())?;
    put(&mut written, "metrics.json".into(), json.into_bytes())?;
    Ok(written)
}

/// What a run that failed leaves under `--out`: `log_<localizer>.txt` for every localizer that
/// kept a log (the failed process localizer's stderr explains the failure) and `error.txt`
/// with the error. Returns the paths written.
pub fn write_failed_run(dir: &Path, err: &crate::ScenarioError) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(dir)
        .map_err(|e| format!("{}: cannot create folder: {e}", dir.display()))?;
    let mut written = Vec::new();
    let mut put = |name: String, bytes: &[u8]| -> Result<(), String> {
        let p = dir.join(name);
        write_atomic(&p, bytes).map_err(|e| format!("{}: cannot write file: {e}", p.display()))?;
        written.push(p);
        Ok(())
    };
    if let crate::ScenarioError::Localizer { logs, .. } = err {
        for (name, log) in logs {
            // Names are checked when the scenario loads; never write outside `dir`.
            if crate::scenario::check_localizer_name(name).is_ok() {
                put(format!("log_{name}.txt"), log.as_bytes())?;
            }
        }
    }
    put("error.txt".into(), format!("{err}\n").as_bytes())?;
    Ok(written)
}

/// The `--json` document of a run that failed: the error, and for a localizer's failure which
/// localizer, on what reading at what time, and the names of the logs kept.
pub fn failed_run_json(err: &crate::ScenarioError) -> serde_json::Value {
    let mut doc = serde_json::json!({ "passed": false, "error": err.to_string() });
    if let crate::ScenarioError::Localizer {
        name,
        reading,
        t,
        logs,
        ..
    } = err
    {
        doc["failed_localizer"] = serde_json::json!({
            "name": name,
            "reading": reading,
            "t": t,
        });
        doc["logs"] = logs
            .iter()
            .map(|(n, l)| (n.clone(), serde_json::Value::String(l.clone())))
            .collect::<serde_json::Map<_, _>>()
            .into();
    }
    doc
}

fn write_figure(
    written: &mut Vec<PathBuf>,
    dir: &Path,
    stem: &str,
    fig: &crate::figure::Figure,
) -> Result<(), String> {
    written.extend(fig.write(dir, stem).map_err(|e| e.to_string())?);
    Ok(())
}

/// Writes the map of `world` a localizer may know: `format` "ros" gives `output` (YAML) and a
/// PGM beside it with the same stem; "vector" gives one `x1,y1,x2,y2` segment per line.
pub fn export_map(
    world: &atrium_worlds::World,
    format: &str,
    output: &Path,
    include_glass: bool,
    resolution: f64,
) -> Result<Vec<std::path::PathBuf>, String> {
    let fail = |e: std::io::Error| format!("{}: {e}", output.display());
    match format {
        "ros" if output.extension().is_some_and(|e| e == "pgm") => Err(format!(
            "-o {}: names the image; give the YAML path (e.g. map.yaml): the image is \
             written beside it with the extension .pgm",
            output.display()
        )),
        "ros" => {
            let mut grid = world
                .try_occupancy_grid(resolution, include_glass)
                .map_err(|e| format!("--resolution: {e}"))?;
            // Outside the building: unknown (205 in the PGM), as the help text says.
            grid.mark_outside_unknown(&[]);
            let pgm = output.with_extension("pgm");
            let image = pgm
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .ok_or_else(|| format!("{}: not a file path", output.display()))?;
            // Both checked before either is written (a folder named m.pgm was reported as a
            // failure to write m.yaml, after nothing or half was written).
            check_writable_file(output, "-o")?;
            check_writable_file(&pgm, "-o (the image beside the YAML)")?;
            write_atomic(&pgm, &grid.to_pgm()).map_err(|e| format!("{}: {e}", pgm.display()))?;
            write_atomic(output, grid.ros_yaml(&image).as_bytes()).map_err(fail)?;
            Ok(vec![output.to_path_buf(), pgm])
        }
        "vector" => {
            check_writable_file(output, "-o")?;
            write_atomic(output, world.vector_map(include_glass).to_text().as_bytes())
                .map_err(fail)?;
            Ok(vec![output.to_path_buf()])
        }
        other => Err(format!("--format: unknown format {other:?} (ros, vector)")),
    }
}

/// Refuses to write `output` when it is one of `inputs` (`atrium record -o scenario.toml`
/// would destroy the scenario): compared after resolving links and `..`.
pub fn refuse_overwriting_inputs(output: &Path, inputs: &[&Path]) -> Result<(), String> {
    let Ok(out) = output.canonicalize() else {
        return Ok(()); // does not exist yet: it is no input
    };
    for input in inputs {
        if input.canonicalize().is_ok_and(|i| i == out) {
            return Err(format!(
                "-o {}: is the input file {}; choose another output",
                output.display(),
                input.display()
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writability_is_checked_without_leaving_anything_behind() {
        let dir = std::env::temp_dir().join(format!("atrium-writable-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // A folder not yet made, under a writable one: fine, and still not made.
        let new = dir.join("a/b");
        check_writable_dir(&new, "--out").unwrap();
        assert!(!dir.join("a").exists());
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            0,
            "the probe was left"
        );
        // Under a file: refused, naming the file.
        let file = dir.join("f.txt");
        std::fs::write(&file, b"x").unwrap();
        let e = check_writable_dir(&file.join("run"), "--out").unwrap_err();
        assert!(
            e.starts_with("--out: ") && e.ends_with("f.txt is not a folder"),
            "{e}"
        );
        let e = check_writable_file(&dir, "-o").unwrap_err();
        assert!(e.contains("is a folder, not a file"), "{e}");
        check_writable_file(&dir.join("out.mcap"), "-o").unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn writes_whole_file_and_leaves_no_temporary() {
        let dir = std::env::temp_dir().join(format!("atrium-output-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.txt");
        write_atomic(&p, b"hello").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"hello");
        let leftovers: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
            .collect();
        assert!(leftovers.is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
