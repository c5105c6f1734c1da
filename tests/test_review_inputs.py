"""``mrcheck review`` input validation: a bad or busy port, a database that cannot be opened or
is not one, a scene manifest without --shots and a missing suggestions file are one line
``error: ...``, exit 1, before the URL is printed and before anything is written.

No server is started: uvicorn is replaced by a stub that fails the test if it is reached."""

from __future__ import annotations

import json
import socket

import numpy as np
import pytest

pytest.importorskip("fastapi")
uvicorn = pytest.importorskip("uvicorn")

from mrcheck.apps.review.server import listen  # noqa: E402
from mrcheck.cli import main  # noqa: E402
from mrcheck.cli.messages import console  # noqa: E402
from mrcheck.core.camera import Camera  # noqa: E402
from mrcheck.core.errors import MrcheckError  # noqa: E402
from mrcheck.core.output import write_image  # noqa: E402
from mrcheck.core.resources import sample_scene_path  # noqa: E402


@pytest.fixture(autouse=True)
def no_server(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("the server must not start for bad input")

    monkeypatch.setattr(uvicorn, "run", refuse)
    monkeypatch.setattr(uvicorn.Server, "run", refuse)


@pytest.fixture()
def outdir(tmp_path):
    """An export folder as ``mrcheck export`` leaves it, as far as the review reads it (no renders)."""
    out = tmp_path / "out"
    camera = Camera.from_look_at((-11.4, -6.2, 1.7), (-5.0, -4.2, 0.9), (0, 0, 1), 60.0, 64, 48)
    write_image(out / "shots" / "shot" / "photo.png", np.full((48, 64, 3), 128, np.uint8))
    (out / "shots" / "shot" / "SHOT.json").write_text(
        json.dumps({**camera.to_dict(), "photo": "photo.png", "rms": 0.1})
    )
    (out / "manifest.json").write_text(
        json.dumps(
            {
                "settings": {"scene": str(sample_scene_path())},
                "shots": [{"name": "shot", "status": "done", "folder": "shots/shot"}],
            }
        )
    )
    return out


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _review(capsys, *args):
    code = main(["review", *map(str, args)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _files(folder):
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*"))


def test_port_out_of_range(outdir, capsys):
    before = _files(outdir)
    code, out, err = _review(capsys, outdir, "--port", 99999)
    assert code == 1 and out == "" and err.startswith("error: ") and "99999" in err and err.count("\n") == 1, err
    assert _files(outdir) == before
    with pytest.raises(MrcheckError, match="port 99999"):  # serve() called directly, without the CLI's check
        listen("127.0.0.1", 99999)


def test_port_in_use_is_reported_before_the_url(outdir, capsys):
    before = _files(outdir)
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        code, out, err = _review(capsys, outdir, "--port", port)
    assert code == 1
    assert err == f"error: port {port} is in use; pick another with --port\n"
    assert "open http" not in out
    assert _files(outdir) == before  # no review.sqlite


@pytest.mark.parametrize("db", ["/proc/x.sqlite", "{tmp}/no/such/folder/review.sqlite", "{tmp}/photo.png"])
def test_database_that_cannot_be_opened(db, outdir, tmp_path, capsys):
    db = db.replace("{tmp}", str(tmp_path))
    photo = (outdir / "shots" / "shot" / "photo.png").read_bytes()
    (tmp_path / "photo.png").write_bytes(photo)  # a file that is not a database
    before = _files(tmp_path)
    code, out, err = _review(capsys, outdir, "--port", _free_port(), "--db", db)
    assert code == 1
    assert err.startswith(f"error: {db}: cannot open the review database (") and err.count("\n") == 1, err
    assert "open http" not in out
    assert _files(tmp_path) == before and (tmp_path / "photo.png").read_bytes() == photo


@pytest.mark.parametrize("kind", ["sample scene", "no parts yet"])
def test_scene_manifest_without_shots_says_what_to_pass(capsys, tmp_path, kind):
    scene = sample_scene_path()
    if kind == "no parts yet":  # still a scene manifest, not a job with unknown keys
        scene = tmp_path / "scene.toml"
        scene.write_text('format = 1\nname = "hall"\n')
    code, out, err = _review(capsys, scene, "--port", _free_port())
    assert code == 1 and err.count("\n") == 1, err
    assert err.startswith(f"error: {scene}: is a scene manifest") and "--shots DIR" in err and "unknown key" not in err


def test_missing_suggestions_file_is_not_found(outdir, tmp_path, capsys):
    missing = tmp_path / "missing.json"
    code, out, err = _review(capsys, outdir, "--port", _free_port(), "--suggestions", missing)
    assert code == 1
    assert err == f"error: {missing}: suggestions file not found\n"
    assert not (outdir / "review.sqlite").exists()


@pytest.mark.parametrize(
    "text, problem",
    [
        ('{"settings": {"sce', "cannot read the export manifest ("),
        ("[]", "not an export manifest (no settings.scene)"),
        ('{"format": 1, "shots": []}', "not an export manifest (no settings.scene)"),
        ('{"settings": {"scene": "s.toml"}, "shots": [{"status": "done"}]}', "not an export manifest (shots must be"),
    ],
)
def test_corrupt_export_manifest_is_named(outdir, capsys, text, problem):
    (outdir / "manifest.json").write_text(text)
    code, out, err = _review(capsys, outdir, "--port", _free_port())
    assert code == 1 and err.startswith(f"error: {outdir / 'manifest.json'}: {problem}") and err.count("\n") == 1, err


def test_moved_scene_is_reported_before_the_url(outdir, tmp_path, capsys):
    gone = tmp_path / "moved" / "scene.toml"
    manifest = json.loads((outdir / "manifest.json").read_text())
    (outdir / "manifest.json").write_text(json.dumps({**manifest, "settings": {"scene": str(gone)}}))
    code, out, err = _review(capsys, outdir, "--port", _free_port())
    assert code == 1 and out == "" and err.startswith(f"error: {gone}: scene not found") and err.count("\n") == 1, err
    assert not (outdir / "review.sqlite").exists()


def test_shot_with_a_missing_photo_is_reported_before_the_url(outdir, tmp_path, capsys):
    shots = tmp_path / "shots"
    shots.mkdir()
    data = json.loads((outdir / "shots" / "shot" / "SHOT.json").read_text())
    (shots / "a.json").write_text(json.dumps({**data, "photo": "missing.png"}))
    code, out, err = _review(capsys, sample_scene_path(), "--shots", shots, "--port", _free_port())
    assert code == 1 and out == "" and err == f"error: {shots / 'missing.png'}: photo of shot 'a' not found\n"


def test_suggestions_from_a_photo_of_another_size_are_refused(outdir, tmp_path, capsys):
    """The review's shot is 64x48; the discrepancies run was made on a 640x480 shot."""
    big = Camera.from_look_at((-11.4, -6.2, 1.7), (-5.0, -4.2, 0.9), (0, 0, 1), 60.0, 640, 480)
    (tmp_path / "big.json").write_text(json.dumps({**big.to_dict(), "photo": "big.png"}))
    suspects = tmp_path / "suspects.json"
    suspects.write_text(json.dumps({"shot": str(tmp_path / "big.json"), "suggested_markers": [{"x": 30, "y": 20}]}))
    code, out, err = _review(capsys, outdir, "--port", _free_port(), "--suggestions", f"shot={suspects}")
    assert code == 1 and err == (
        f"error: {suspects}: made on a 640x480 shot ({tmp_path / 'big.json'}), but shot 'shot' is 64x48\n"
    ), err
    # its shot file gone: a marker outside the image gives it away
    suspects.write_text(json.dumps({"shot": str(tmp_path / "gone.json"), "suggested_markers": [{"x": 500, "y": 400}]}))
    code, out, err = _review(capsys, outdir, "--port", _free_port(), "--suggestions", f"shot={suspects}")
    assert (
        code == 1
        and err.startswith(f"error: {suspects}: a suggested marker at (500, 400) lies outside")
        and err.count("\n") == 1
    ), err
    assert not (outdir / "review.sqlite").exists()


@pytest.mark.parametrize("token", ["", "   "])
def test_an_empty_token_is_refused(outdir, capsys, token):
    """An empty --token started a server that answered every request, ?token= included, with 401."""
    before = _files(outdir)
    code, out, err = _review(capsys, outdir, "--host", "0.0.0.0", "--port", _free_port(), "--token", token)
    assert code == 1 and err.startswith("error: --token must not be empty") and err.count("\n") == 1
    assert "open http" not in out and _files(outdir) == before


def test_suggestions_for_a_photo_two_shots_share_need_a_name(outdir, tmp_path, capsys):
    """Two shots of one photo: the suggestions went to the first one silently; now the name is asked for."""
    import shutil

    shutil.copytree(outdir / "shots" / "shot", outdir / "shots" / "again")
    manifest = json.loads((outdir / "manifest.json").read_text())
    manifest["shots"].append({"name": "again", "status": "done", "folder": "shots/again"})
    (outdir / "manifest.json").write_text(json.dumps(manifest))
    again = json.loads((outdir / "shots" / "again" / "SHOT.json").read_text())
    again["photo"] = str(outdir / "shots" / "shot" / "photo.png")  # the same photo file
    (outdir / "shots" / "again" / "SHOT.json").write_text(json.dumps(again))
    suspects = tmp_path / "suspects.json"
    suspects.write_text(
        json.dumps({"shot": str(outdir / "shots" / "shot" / "SHOT.json"), "suggested_markers": [{"x": 30, "y": 20}]})
    )
    code, out, err = _review(capsys, outdir, "--port", _free_port(), "--suggestions", suspects)
    assert code == 1 and err.count("\n") == 1, err
    assert err.startswith(f"error: {suspects}: its photo is the photo of shots again, shot; pass NAME=FILE")


def _shots_folder(outdir, folder):
    """A folder of one SHOT.json (the export's shot) for ``SCENE --shots DIR``."""
    folder.mkdir()
    data = json.loads((outdir / "shots" / "shot" / "SHOT.json").read_text())
    (folder / "a.json").write_text(json.dumps({**data, "photo": str(outdir / "shots" / "shot" / "photo.png")}))
    return folder


def test_a_scene_that_does_not_load_is_reported_before_the_url(outdir, tmp_path, capsys):
    """A corrupt mesh started the server; every render, pick and marker then failed with a 404."""
    shots = _shots_folder(outdir, tmp_path / "shots")
    (tmp_path / "box.stl").write_text("solid garbage\n")
    before = _files(tmp_path)
    code, out, err = _review(capsys, tmp_path / "box.stl", "--shots", shots, "--port", _free_port())
    assert code == 1 and out == "" and err.startswith(f"error: {tmp_path / 'box.stl'}: ") and err.count("\n") == 1, err
    assert _files(tmp_path) == before


def test_a_job_or_an_export_given_as_scene_says_so(outdir, tmp_path, capsys):
    shots = _shots_folder(outdir, tmp_path / "shots")
    job = tmp_path / "job.toml"
    job.write_text(f'scene = "{sample_scene_path()}"\n[[shots]]\nshot = "{shots / "a.json"}"\n')
    for target, kind in ((job, "a job file"), (outdir, "an export folder")):
        code, out, err = _review(capsys, target, "--shots", shots, "--port", _free_port())
        assert (
            code == 1 and out == "" and err == f"error: {target}: is {kind}, not a scene: review it without --shots\n"
        )


@pytest.mark.parametrize(
    "photo, problem",
    [
        (b"garbage\n", "cannot read photo: a text file, not an image"),
        (np.full((24, 32, 3), 128, np.uint8), "photo is 32x24 but the shot was registered at 64x48"),
    ],
)
def test_a_photo_that_does_not_fit_its_shot_is_reported_before_the_url(outdir, capsys, photo, problem):
    """A corrupt photo, or one of another size than its SHOT.json: the server started, and the
    shot failed only when it was looked at."""
    path = outdir / "shots" / "shot" / "photo.png"
    if isinstance(photo, bytes):
        path.write_bytes(photo)
    else:
        write_image(path, photo)
    before = _files(outdir)
    code, out, err = _review(capsys, outdir, "--port", _free_port())
    assert code == 1 and out == "" and err == f"error: {path}: {problem}\n", err
    assert _files(outdir) == before


def _suspects(outdir, folder, markers):
    path = folder / "suspects.json"
    path.write_text(json.dumps({"shot": str(outdir / "shots" / "shot" / "SHOT.json"), "suggested_markers": markers}))
    return path


@pytest.mark.parametrize(
    "marker, problem",
    [
        ({"x": 1, "y": 1, "severity": "high"}, "severity must be 1, 2 or 3, got 'high'"),
        ({"x": 1, "y": 1, "severity": 9}, "severity must be 1, 2 or 3, got 9"),
        ({"x": 1, "y": 1, "severity": True}, "severity must be 1, 2 or 3, got True"),
        ({"x": "1", "y": 1}, "x (photo pixels): '1' is not a number"),
        ({"x": 1, "y": 1, "note": 5}, "note must be a string, got 5"),
    ],
)
def test_a_bad_suggested_marker_is_named(outdir, tmp_path, capsys, marker, problem):
    """A severity "high" was an internal error; 9 was imported, which the page cannot show."""
    suspects = _suspects(outdir, tmp_path, [{"x": 2, "y": 2}, marker])
    code, out, err = _review(capsys, outdir, "--port", _free_port(), "--suggestions", suspects)
    assert code == 1 and err == f"error: {suspects}: suggested marker 2: {problem}\n", err
    assert not (outdir / "review.sqlite").exists()


@pytest.mark.slow
def test_the_suggestions_count_is_what_was_imported(outdir, tmp_path, capsys, monkeypatch):
    """Every start printed the file's count, also when nothing was new; the same file twice counted twice."""
    monkeypatch.setattr(uvicorn.Server, "run", lambda self, sockets=None: None)  # start, print, stop
    suspects = _suspects(outdir, tmp_path, [{"x": 20, "y": 20, "part": "floor"}, {"x": 40, "y": 30}])
    for expected in ("2 new marker(s) on 1 shot(s)", "0 new marker(s) on 0 shot(s)"):
        code, out, err = _review(
            capsys, outdir, "--port", _free_port(), "--suggestions", suspects, "--suggestions", suspects
        )
        assert code == 0 and f"suggestions: {expected} " in out, out + err


def test_a_shots_folder_skips_what_is_not_a_shot(outdir, tmp_path, capsys):
    """One stray JSON (the intrinsics, the clicked points, a broken shot) or a non-ASCII file name
    refused the whole review."""
    from mrcheck.apps.review.source import open_source

    shots = _shots_folder(outdir, tmp_path / "shots")
    (shots / "Halle_Süd.json").write_text((shots / "a.json").read_text())
    (shots / "canon.json").write_text(
        json.dumps({"width": 64, "height": 48, "K": [[50, 0, 32], [0, 50, 24], [0, 0, 1]]})
    )
    (shots / "corners.json").write_text(json.dumps({"points": [{"pixel": [1, 2], "world": [0, 0, 0]}]}))
    (shots / "broken.json").write_text('{"width": 64,')
    with console():  # warnings as the command shows them: lines on stderr
        source = open_source(sample_scene_path(), shots)
    out, err = capsys.readouterr()
    assert sorted(source.shots) == ["Halle_S_d", "a"] and out == ""
    assert err.count("\n") == 3 and all(
        f"warning: {shots / name}: " in err for name in ("canon.json", "corners.json", "broken.json")
    )
    assert f'warning: {shots / "canon.json"}: shot JSON has no "photo" path (skipped: not a usable shot)\n' in err


def test_an_export_says_which_shots_it_cannot_review(outdir, capsys):
    """A done shot whose SHOT.json was deleted vanished without a word; an export whose every shot
    failed said only "no usable shots"."""
    import shutil

    from mrcheck.apps.review.source import open_source

    shutil.copytree(outdir / "shots" / "shot", outdir / "shots" / "gone")
    (outdir / "shots" / "gone" / "SHOT.json").unlink()
    manifest = json.loads((outdir / "manifest.json").read_text())
    manifest["shots"].append({"name": "gone", "status": "done", "folder": "shots/gone"})
    (outdir / "manifest.json").write_text(json.dumps(manifest))
    with console():
        assert list(open_source(outdir).shots) == ["shot"]
    err = capsys.readouterr().err
    assert err == f"warning: shot gone skipped: {outdir / 'shots' / 'gone' / 'SHOT.json'}: shot file not found\n"
    manifest["shots"] = [{**e, "status": "failed"} for e in manifest["shots"]]
    (outdir / "manifest.json").write_text(json.dumps(manifest))
    code, out, err = _review(capsys, outdir, "--port", _free_port())
    assert code == 1 and err == (
        f"error: {outdir}: no usable shots to review: every shot (2) failed in the export; its report.html says why\n"
    ), err


def test_an_empty_shots_folder_is_named(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    code, out, err = _review(capsys, sample_scene_path(), "--shots", tmp_path / "empty", "--port", _free_port())
    assert (
        code == 1
        and err == f"error: {tmp_path / 'empty'}: no usable shots to review: it has no SHOT.json files (*.json)\n"
    )


def test_a_corrupt_shot_json_is_said_once(tmp_path, capsys):
    """json's "Invalid control character at" gave "... at at line 1"."""
    from mrcheck.apps.review.source import open_source

    (tmp_path / "a.json").write_text('{"photo": "a\nb.png"}')
    with pytest.raises(MrcheckError) as info, console():
        open_source(sample_scene_path(), tmp_path)
    assert (
        f"warning: {tmp_path / 'a.json'}: malformed shot JSON: Invalid control character at line 1 (skipped"
        in capsys.readouterr().err
    )
    assert "at at" not in str(info.value)


def test_another_programs_database_is_refused(outdir, tmp_path, capsys):
    """Its file got the review's tables (and WAL mode) added."""
    import sqlite3

    other = tmp_path / "other.sqlite"
    with sqlite3.connect(other) as db:
        db.execute("CREATE TABLE foo (x)")
    db.close()
    before = other.read_bytes()
    code, out, err = _review(capsys, outdir, "--port", _free_port(), "--db", other)
    assert (
        code == 1
        and err == f"error: {other}: not a review database (it has the table(s) foo): give a new file with --db\n"
    )
    assert other.read_bytes() == before and "open http" not in out


def test_an_empty_db_is_refused(outdir, capsys):
    """--db "" used the default database silently."""
    code, out, err = _review(capsys, outdir, "--port", _free_port(), "--db", "")
    assert code == 1 and err.startswith("error: --db must not be empty") and err.count("\n") == 1
    assert not (outdir / "review.sqlite").exists()


def test_a_database_with_other_reviews_says_so(outdir, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(uvicorn.Server, "run", lambda self, sockets=None: None)  # start, print, stop
    db = tmp_path / "team.sqlite"
    shots = _shots_folder(outdir, tmp_path / "shots")
    assert _review(capsys, outdir, "--port", _free_port(), "--db", db)[0] == 0
    code, out, err = _review(capsys, sample_scene_path(), "--shots", shots, "--port", _free_port(), "--db", db)
    assert (
        code == 0
        and f"review database {db}: a new review of {shots}; its other review(s), kept apart: {outdir}\n" in out
    ), out


def test_the_url_for_every_interface_names_the_machine(outdir, capsys, monkeypatch):
    """--host 0.0.0.0 printed http://0.0.0.0:PORT/, which cannot be sent to a colleague."""
    monkeypatch.setattr(uvicorn.Server, "run", lambda self, sockets=None: None)  # start, print, stop
    port = _free_port()
    code, out, err = _review(capsys, outdir, "--host", "0.0.0.0", "--port", port)
    assert code == 0 and f"open http://{socket.gethostname()}:{port}/?token=" in out, out
