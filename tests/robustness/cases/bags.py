"""Bad input against ROS bags and CSV exports (`convert`)."""

from __future__ import annotations

import shutil

from tests.robustness.harness import Attempt, Case, registrar, trial


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []
    case = registrar(found)


    # --- convert -----------------------------------------------------------------------------
    def convert_case(name, build):
        def prepare(s, d):
            src, named = build(s, d)
            return Attempt(argv=["convert", str(src), "--out", str(d / "out.csv")],
                           names=(str(named),))
        found.append(Case("cli convert", name, "REJECTED", prepare))

    def missing_bag(s, d):
        return d / "run.mcap", d / "run.mcap"

    def empty_bag(s, d):
        (d / "run.mcap").write_bytes(b"")
        return d / "run.mcap", d / "run.mcap"

    def text_bag(s, d):
        (d / "run.bag").write_text("not a bag\n")
        return d / "run.bag", d / "run.bag"

    def empty_bag_folder(s, d):
        (d / "bag").mkdir()
        return d / "bag", d / "bag"

    def csv_with_map(text):
        def build(s, d):
            shutil.copy(trial(s.bench), d / "e.csv")
            (d / "map.json").write_text(text)
            return d / "e.csv", d / "map.json"
        return build

    convert_case("missing bag", missing_bag)
    convert_case("zero-byte .mcap", empty_bag)
    convert_case("text file as ROS 1 bag", text_bag)
    convert_case("empty folder as ROS 2 bag", empty_bag_folder)
    for text, name in (("[1, 2]", "column map a list"), ("{not json", "column map not JSON"),
                       ('{"no_such_column": "time"}', "column map names absent columns")):
        def with_map(s, d, text=text):
            src, mp = csv_with_map(text)(s, d)
            return Attempt(argv=["convert", str(src), "--column-map", str(mp),
                                 "--out", str(d / "out.csv")], names=(str(mp), str(src)))
        found.append(Case("cli convert", name, "REJECTED", with_map))
    @case("cli convert", "--out is a folder")
    def _(s, d):
        src = d / "e.csv"
        shutil.copy(trial(s.bench), src)
        return Attempt(argv=["convert", str(src), "--out", str(d)], names=("--out",))
    for rate in ("0", "-5", "nan"):
        def bad_rate(s, d, rate=rate):
            (d / "bag").mkdir()
            return Attempt(argv=["convert", str(d / "bag"), "--rate", rate,
                                 "--out", str(d / "out.csv")], names=("--rate", "rate"))
        found.append(Case("cli convert", f"--rate {rate}", "REJECTED", bad_rate))
    for text, name in (("[[1, 0], [0, 1]]", "--r-ati-psm 2x2"),
                       ("[[2, 0, 0], [0, 2, 0], [0, 0, 2]]", "--r-ati-psm not a rotation"),
                       ("rotation", "--r-ati-psm not JSON")):
        def bad_rotation(s, d, text=text):
            (d / "bag").mkdir()
            (d / "r.json").write_text(text)
            return Attempt(argv=["convert", str(d / "bag"), "--r-ati-psm", str(d / "r.json"),
                                 "--out", str(d / "out.csv")],
                           names=("--r-ati-psm", str(d / "r.json")))
        found.append(Case("cli convert", name, "REJECTED", bad_rotation))
    return found
