"""Bad input against internal-force priors: damaged files, and the envelope of prior files."""

from __future__ import annotations

import json

import numpy as np

from psmforce.identification.prior import FORMAT_VERSION as PRIOR_FORMAT_VERSION
from tests.robustness.harness import Attempt, Case, _register, edit_csv, registrar, trial


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []
    case = registrar(found)


    # --- priors ------------------------------------------------------------------------------
    def prior_file(s, d, edit):
        """The shared prior with ``edit`` applied: text as given, an edited document resealed
        (a careless tool), so that its parameter bounds, not its envelope, must refuse it."""
        from psmforce.core.integrity import seal
        path = d / "prior.json"
        doc = json.loads(s.prior.read_text())
        text = edit(doc)
        path.write_text(text if isinstance(text, str) else json.dumps(seal(doc)))
        return path

    def set_param(name, value):
        def edit(doc):
            doc["parameters"][name]["value"] = value
        return edit

    prior_damage = {
        "zero-byte": lambda doc: "",
        "not JSON": lambda doc: "prior: yes\n",
        "a list": lambda doc: "[1, 2, 3]",
        "a string": lambda doc: '"prior"',
        "another format": lambda doc: json.dumps({"format": "psm-arm-dynamics"}),
        "string parameter": set_param("bias_fz", "0.1"),
        "NaN parameter": set_param("pretension_total", float("nan")),
        "infinite parameter": set_param("bias_fx", float("inf")),
        "negative pulley radius": set_param("pulley_radius_pitch", -1.0),
        "null parameter": set_param("distal_mass", None),
        "parameters a list": lambda doc: json.dumps({**doc, "parameters": [1, 2]}),
    }
    for damage, edit in prior_damage.items():
        def load(s, d, edit=edit):
            from psmforce.identification.prior import InternalForcePrior
            path = prior_file(s, d, edit)
            return Attempt(call=lambda: InternalForcePrior.load(path), names=(str(path),))
        found.append(Case("api InternalForcePrior.load", damage, "REJECTED", load))

        def train_with(s, d, edit=edit):
            path = prior_file(s, d, edit)
            return Attempt(argv=["train", "--data", str(s.bench), "--model", "hybrid",
                                 "--prior", str(path), "--epochs", "1", "--out", str(d / "h.pt")],
                           names=(str(path),))
        found.append(Case("cli train --prior", damage, "REJECTED", train_with))

    @case("cli train --prior", "missing file")
    def _(s, d):
        return Attempt(argv=["train", "--data", str(s.bench), "--model", "hybrid", "--prior",
                             str(d / "none.json"), "--epochs", "1", "--out", str(d / "h.pt")],
                       names=(str(d / "none.json"),))

    @case("cli fit-prior", "one training trial reads fz = 1e6 N (poor fit)")
    def _(s, d):
        data = s.copy(d)
        edit_csv(trial(data), lambda f: f.assign(fz=1e6))
        out = d / "p.json"
        return Attempt(argv=["fit-prior", "--data", str(data), "--out", str(out)],
                       names=("--accept-poor-fit",))

    @case("cli fit-prior", "--data missing")
    def _(s, d):
        return Attempt(argv=["fit-prior", "--data", str(d / "none"), "--out", str(d / "p.json")],
                       names=(str(d / "none"),))

    @case("cli fit-prior", "--out is a folder")
    def _(s, d):
        return Attempt(argv=["fit-prior", "--data", str(s.bench), "--out", str(d)],
                       names=("--out", str(d)), guard="psmforce.identification.fit_prior_cli")

    @case("cli fit-prior", "--json into a missing folder")
    def _(s, d):
        return Attempt(argv=["fit-prior", "--data", str(s.bench), "--out", str(d / "p.json"),
                             "--json", str(d / "no" / "p.json")], names=("--json",),
                       guard="psmforce.identification.fit_prior_cli")

    # --- priors: the envelope of prior files ---

    def edited_prior(s, d, edit, reseal=False):
        from psmforce.core.integrity import seal
        doc = json.loads(s.prior.read_text())
        edit(doc)
        path = d / "prior.json"
        path.write_text(json.dumps(seal(doc) if reseal else doc))
        return path

    def in_bounds(doc):
        entry = doc["parameters"]["bias_fz"]
        entry["value"] = entry["lower"] + 0.37 * (entry["upper"] - entry["lower"])

    edits = {
        "a parameter edited inside its bounds": (in_bounds, False),
        "axis_weights edited": (lambda doc: doc.update(axis_weights=[0.5] * 6), False),
        "insertion model edited": (lambda doc: doc["insertion"].update(note="edited"), False),
        "converged flipped": (lambda doc: doc.update(converged=False), False),
        "a field added": (lambda doc: doc.update(note="trust me"), False),
        "envelope removed, version kept": (lambda doc: doc.pop("sha256"), False),
        "version removed, envelope kept": (lambda doc: doc.pop("format_version"), False),
        "format_version '2' (text)": (lambda doc: doc.update(format_version="2"), True),
        "format_version 2.0 (float)": (lambda doc: doc.update(format_version=2.0), True),
        "format_version true": (lambda doc: doc.update(format_version=True), True),
        # a version this library has not written yet (older versions are read, upgraded)
        "format_version one past the newest": (
            lambda doc: doc.update(format_version=PRIOR_FORMAT_VERSION + 1), True),
        "format_version 1 (before the envelope)": (lambda doc: doc.update(format_version=1), True),
    }
    for damage, (edit, reseal) in edits.items():
        def load(s, d, edit=edit, reseal=reseal):
            from psmforce.identification.prior import InternalForcePrior
            path = edited_prior(s, d, edit, reseal)
            return Attempt(call=lambda: InternalForcePrior.load(path), names=(str(path),))
        found.append(Case("api InternalForcePrior.load: envelope", damage, "REJECTED", load))

        def train_with(s, d, edit=edit, reseal=reseal):
            path = edited_prior(s, d, edit, reseal)
            return Attempt(argv=["train", "--data", str(s.bench), "--model", "hybrid",
                                 "--prior", str(path), "--epochs", "1", "--out", str(d / "h.pt")],
                           names=(str(path),), guard="psmforce.estimators.training.train.train_model")
        found.append(Case("cli train --prior: envelope", damage, "REJECTED", train_with))

    def legacy(doc):
        doc.pop("sha256")
        doc.pop("format_version")

    @_register(found, "api InternalForcePrior.load: envelope",
               "a file written before the envelope loads", "HANDLED")
    def _(s, d):
        from psmforce.identification.prior import InternalForcePrior
        path = edited_prior(s, d, legacy)

        def check(prior):
            same = np.array_equal(prior.params, InternalForcePrior.load(s.prior).params)
            return same, f"loaded, parameters as written: {same}"
        return Attempt(call=lambda: InternalForcePrior.load(path), check=check)
    return found
