"""Controller files in every format: the templates read back as the plants' predefined
laws, the seed's controllers as a student would save them from MATLAB or NumPy, and every
kind of bad file refused with the field (or the line and column) and what is allowed."""

from __future__ import annotations

import io
import json
import zipfile

import numpy as np
import pytest
import scipy.io

from elab.controllers import FORMATS, read_controller, template
from elab.controllers.file_format import MAX_BYTES
from elab.errors import InvalidInput
from elab.laws import PID, LTIController, StateFeedback
from elab.plants import PLANTS, get_plant

FLEX = get_plant("flexible_link")
BELT = get_plant("belt_conveyor")
SEED_LQR = (20.0, -93.5614, 3.3621, 0.9623)  # seed eq. 4.6


@pytest.mark.parametrize("fmt", [f for f in FORMATS if f != "py"])
@pytest.mark.parametrize("plant_id", list(PLANTS))
def test_every_template_reads_back_as_the_predefined_controller(plant_id: str, fmt: str) -> None:
    plant = get_plant(plant_id)
    ctrl = read_controller(template(plant, fmt), fmt, plant)
    assert ctrl.law == plant.predefined


def mat(**arrays: object) -> bytes:
    buf = io.BytesIO()
    scipy.io.savemat(buf, arrays)
    return buf.getvalue()


def npz(**arrays: object) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)  # type: ignore[arg-type]
    return buf.getvalue()


def test_the_seeds_controllers_as_students_save_them() -> None:
    toml = f'version = 1\nkind = "state_feedback"\nK = {list(SEED_LQR)}\n'.encode()
    assert read_controller(toml, "toml", FLEX).law == StateFeedback(SEED_LQR, "velocity_filters")
    # MATLAB: K = lqr(...); save ctrl.mat K  (a 1x4 row)
    assert read_controller(mat(K=np.array([SEED_LQR])), "mat", FLEX).law.K == SEED_LQR  # type: ignore[union-attr]
    # python-control users: np.savez("ctrl.npz", K=K) with K of shape (1, 4)
    assert read_controller(npz(K=np.array([SEED_LQR])), "npz", FLEX).law.K == SEED_LQR  # type: ignore[union-attr]
    seed_pid = PID(12.0, 0.49, 0.5)
    body = json.dumps({"version": 1, "kind": "pid", "Kp": 12, "Ki": 0.49, "Kd": 0.5})
    assert read_controller(body.encode(), "json", BELT).law == seed_pid
    assert read_controller(mat(Kp=12.0, Ki=0.49, Kd=0.5), "mat", BELT).law == seed_pid


def test_a_state_space_controller_from_matlab_keeps_its_shapes_and_sample_time() -> None:
    # [A,B,C,D] = ssdata(c2d(C, Ts)); save -v7 ctrl.mat A B C D Ts — C is a 1x2 row
    A = np.array([[1.0, 0.001], [0.0, 0.9]])
    B, C, D = np.array([[0.0], [1.0]]), np.array([[2.0, 0.5]]), np.array([[0.1]])
    law = read_controller(mat(A=A, B=B, C=C, D=D, Ts=0.001), "mat", BELT).law
    assert law == LTIController(
        A=((1.0, 0.001), (0.0, 0.9)), B=((0.0,), (1.0,)), C=((2.0, 0.5),), D=((0.1,),), dt=0.001
    )
    cont = read_controller(mat(num=[[1.0, 2.0]], den=[[1.0, 3.0]], Ts=0.0), "mat", BELT).law
    assert cont == LTIController(num=(1.0, 2.0), den=(1.0, 3.0), dt=None)  # Ts = 0: continuous


def refused(data: bytes, fmt: str, field: str, *words: str) -> None:
    with pytest.raises(InvalidInput) as err:
        read_controller(data, fmt, FLEX)
    assert err.value.field == field, str(err.value)
    for w in words:
        assert w in str(err.value), str(err.value)


def test_syntax_errors_say_where() -> None:
    refused(b'version = 1\nkind = "pid"\nKp = [1,\n', "toml", "file", "line 4, the end of")
    refused(b'version = 1\nkind = = "pid"\n', "toml", "file", "line 2, column 8")
    refused(b'{"version": 1,\n "kind": "pid", "Kp": }', "json", "file", "line 2, column 23")
    refused(b'{"version": 1, "kind": "pid", "Kp": NaN}', "json", "file", "finite")
    refused(b"[" * 100_000 + b"]" * 100_000, "json", "file")


@pytest.mark.parametrize(
    ("text", "field", "words"),
    [
        ('kind = "pid"\nKp = 1', "version", ("version = 1",)),
        ('version = 2\nkind = "pid"\nKp = 1', "version", ("1",)),
        ('version = 1\nkind = "fuzzy"', "kind", ("state_feedback, pid, lti, chain, open_loop",)),
        ('version = 1\nkind = "pid"\nKp = 1\nKq = 2', "Kq", ("Kp, Ki, Kd, N, Tt",)),
        ('version = 1\nkind = "state_feedback"\nK = [1, 2]', "K", ("4 numbers",)),
        ('version = 1\nkind = "state_feedback"\nK = [1, 2, 3, nan]', "K.3", ("finite",)),
        ('version = 1\nkind = "state_feedback"\nK = [1, 2, 3, "x"]', "K.3", ("a number",)),
        ('version = 1\nkind = "state_feedback"\nK = [1, 2, 3, 4]\nestimate = "x"', "estimate", ()),
        ('version = 1\nplant = "belt_conveyor"\nkind = "pid"\nKp = 1', "plant", ("flexible_link",)),
        ('version = 1\nkind = "pid"\nKp = 1\nN = 0', "N", ("positive",)),
        ('version = 1\nkind = "lti"\nnum = [1]\nden = [0, 1]', "den", ("leading",)),
        ('version = 1\nkind = "lti"\nnum = [1, 2, 3]\nden = [1, 1]', "num", ("proper",)),
        ('version = 1\nkind = "lti"\nnum = [1]\nden = [1, 1]\nA = [[1]]', "kind", ("not both",)),
        ('version = 1\nkind = "lti"\nA = [[1, 2]]\nB = [[1]]\nC = [[1]]', "A", ("square",)),
        ('version = 1\nkind = "lti"\nA = [[1]]\nB = [[1], [2]]\nC = [[1]]', "B", ("1×1",)),
    ],
)
def test_fields_that_do_not_fit_are_named(text: str, field: str, words: tuple[str, ...]) -> None:
    refused(text.encode(), "toml", field, *words)


def test_files_that_are_too_big_not_text_or_not_what_they_claim() -> None:
    refused(b"#" * (MAX_BYTES + 1), "toml", "file", f"{MAX_BYTES} bytes")
    refused(b"", "toml", "file", "empty")
    refused(b"version = 1\nname = '\xff\xfe'", "toml", "file", "UTF-8")
    refused(b"not a mat file at all", "mat", "file", "save -v7")
    refused(b"not a zip", "npz", "file", "numpy.savez")


def test_matlab_v73_files_and_objects_get_the_one_line_fix() -> None:
    v73 = b"MATLAB 7.3 MAT-file, Platform: GLNXA64".ljust(512, b" ") + b"\x89HDF\r\n\x1a\n"
    refused(v73, "mat", "file", "v7.3", "save -v7 ctrl.mat A B C D Ts")
    cell = np.empty((1, 1), dtype=object)
    cell[0, 0] = np.array([[1.0]])
    refused(mat(K=cell), "mat", "K", "no ss/tf objects")
    refused(mat(P=np.array([[1.0]])), "mat", "file", "K (state feedback)")


def test_npz_pickles_and_bombs_are_never_opened() -> None:
    refused(npz(K=np.array([{"evil": 1}], dtype=object)), "npz", "file", "never loaded")
    bomb = io.BytesIO()
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("K.npy", b"\0" * (8 << 20))  # 8 MiB of zeros: a few KiB compressed
    assert len(bomb.getvalue()) < MAX_BYTES
    refused(bomb.getvalue(), "npz", "file", "expanded")
