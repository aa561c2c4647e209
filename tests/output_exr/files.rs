//! Where files go: folders made on the way, failed writes that leave the target as it was.

use super::*;

#[test]
fn missing_folders_are_made_and_one_that_cannot_be_fails_naming_the_path() {
    let dir = scratch("missing-dir");
    let made = dir.join("no/such/dir/frame.exr");
    write_exr(&made, &test_frame(), &ExrOptions::default()).unwrap();
    assert!(made.is_file());
    // Under a regular file no folder can be made, even as root.
    fs::write(dir.join("file"), "x").unwrap();
    let path = dir.join("file/no/frame.exr");
    let err = write_exr(&path, &test_frame(), &ExrOptions::default()).unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains(&path.display().to_string()), "{msg}");
    assert!(msg.contains("cannot create the folder"), "{msg}");
    let png = dir.join("file/preview.png");
    let msg = write_preview(&png, &test_frame(), &PreviewOptions::default())
        .unwrap_err()
        .to_string();
    assert!(msg.contains(&png.display().to_string()), "{msg}");
    assert_eq!(fs::read_to_string(dir.join("file")).unwrap(), "x");
}

#[test]
fn failed_writes_leave_the_existing_target_untouched() {
    need!(tools::EXRHEADER);
    let dir = scratch("untouched");
    let path = dir.join("frame.exr");
    write_exr(&path, &test_frame(), &test_options()).unwrap();
    let before = fs::read(&path).unwrap();

    // rejected before writing: a frame without channels, a reserved attribute name
    let e = write_exr(&path, &Frame::new(W, H), &test_options()).unwrap_err();
    assert!(e.to_string().contains(&path.display().to_string()), "{e}");
    let mut opts = test_options();
    opts.extra_strings
        .push(("dataWindow".to_owned(), "x".to_owned()));
    assert!(write_exr(&path, &test_frame(), &opts).is_err());

    // fails after the temporary file was written
    let e: Result<(), OutputError> = write_atomically(&path, |tmp| {
        fs::write(tmp, b"half a file").unwrap();
        Err(OutputError::File(FileError::Invalid {
            path: path.clone(),
            reason: "simulated failure".into(),
        }))
    });
    assert!(e.is_err());
    assert_eq!(fs::read(&path).unwrap(), before, "target changed");
    no_temp_files(&dir);

    // the target is a non-empty directory: refused by the output guard
    let blocker = dir.join("blocked.exr");
    fs::create_dir(&blocker).unwrap();
    fs::write(blocker.join("keep"), b"keep").unwrap();
    let e = write_exr(&blocker, &test_frame(), &test_options()).unwrap_err();
    assert!(
        matches!(e, OutputError::File(FileError::Refused { .. })),
        "{e:?}"
    );
    assert!(
        e.to_string().contains(&blocker.display().to_string()),
        "{e}"
    );
    assert_eq!(fs::read(blocker.join("keep")).unwrap(), b"keep");
    no_temp_files(&dir);
    exrheader(&path); // still a valid file
}
