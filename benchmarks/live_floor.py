"""The floor under what ``psmforce serve`` adds: the same node without its estimator.

    python benchmarks/live_floor.py CHECKPOINT --domain-id N --json OUT [--rt-priority P]

:class:`EchoNode` is :class:`psmforce.live.serve.DdsNode` (its readers, writers, wake-ups, takes,
decoding and ordering, its residence bookkeeping, ``_keep_residence``) with
:meth:`EchoNode._handle` answering each HEX10 message with four outputs encoded once and
restamped with the message's stamp: no sample, no estimator step, no encoding.
``benchmarks/live.py`` runs it where it runs ``serve`` and measures it the same way
(``dds_floor*``): what any node of this design adds on the host, so the node's own share is its
figure less this one. Stops 3 s after the last message, as ``serve
--idle-stop 3`` does, and writes the report (:meth:`DdsNode.report` and ``scheduling``) to OUT.
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402

from psmforce.experiments.report import write_json  # noqa: E402
from psmforce.io.bags.messages import stamp_ns  # noqa: E402
from psmforce.live import cdr  # noqa: E402
from psmforce.live.discovery import participant  # noqa: E402
from psmforce.live.serve import DdsNode  # noqa: E402


class EchoNode(DdsNode):
    """A :class:`DdsNode` that answers without estimating (module docstring)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        zero = [0.0, 0.0, 0.0]
        self._echo = {"base": cdr.wrench_stamped(0, self.arm + "_base", zero),
                      "hex10": cdr.wrench_stamped(0, "hex10", zero),
                      "flags": cdr.uint32(0),
                      "status": cdr.diagnostic_array(0, "hex10", [])}
        self._stamped = ("base", "hex10", "status")

    def _handle(self, stream: str, message, taken_ns: int) -> None:
        if stream != "hex10":
            return
        stamp = stamp_ns(message) or 0
        writing = time.perf_counter_ns()
        for name, data in self._echo.items():
            self._write(self.writers[name],
                        bytes(cdr.restamp(data, stamp)) if name in self._stamped else data)
        self._keep_residence(taken_ns, writing, time.perf_counter_ns())
        self.published += 1


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkpoint")
    parser.add_argument("--domain-id", type=int, required=True)
    parser.add_argument("--rt-priority", type=int)
    parser.add_argument("--json", required=True)
    args = parser.parse_args()
    from psmforce.live.scheduling import run_realtime
    scheduling = run_realtime(args.rt_priority)  # before the participant, as serve does
    node = EchoNode(args.checkpoint, participant(args.domain_id), input_rate_hz=1000.0,
                    sync=True, domain_id=args.domain_id)
    print(json.dumps({"listening": list(node.input_topics.values())}), flush=True)
    write_json(args.json, {**node.spin(idle_stop_s=3.0), "scheduling": scheduling})


if __name__ == "__main__":
    main()
