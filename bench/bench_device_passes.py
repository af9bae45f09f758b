"""Where a bake's device time goes, pass by pass, in measures a busy machine does not distort: each
kernel's CPU seconds (its work) and how many of the device's worker threads were runnable while it ran
(its parallelism), for B1 and each default LUT.

    python bench/bench_device_passes.py [--device pocl-system] [--bands 32] [--json FILE]

Each LUT is planned and baked in --bands bands (as `lutbake bake` cuts it) on one integrator, every kernel
launch waited for before the next (so each one's time is its own); the process's CPU time is summed per
kernel, and a sampler thread reads every thread's state (/proc/self/task/*/stat) every 2 ms, counting the
threads other than the main one in state R while each kernel runs. On a machine whose other processes
take the cores, a device worker that waits its turn is still R: the count says whether the runtime gave
the kernel's work to its threads, not whether the machine ran them (a count near 1 on a 2-thread device:
one thread had all the work). No EXR is written.
"""

from __future__ import annotations

import argparse
import collections
import os
import threading
import time

from bench_b1 import B1_AXES, _spec, load_average, write_report

SAMPLE_S = 0.002


class Sampler:
    """Runnable threads besides the main one (``with_main``: and it) and itself, counted per ``phase`` every
    SAMPLE_S; ``histogram``: samples by how many were runnable."""

    def __init__(self, with_main: bool = False) -> None:
        self.phase = "host"
        self.samples: dict[str, list[int]] = collections.defaultdict(lambda: [0, 0])  # phase -> [samples, R]
        self.histogram: collections.Counter[int] = collections.Counter()
        self._main = None if with_main else threading.get_native_id()
        self._stop = False
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        me = threading.get_native_id()
        while not self._stop:
            runnable = 0
            for tid in os.listdir("/proc/self/task"):
                if int(tid) in (me, self._main):
                    continue
                try:
                    with open(f"/proc/self/task/{tid}/stat") as stat:
                        runnable += stat.read().rsplit(")", 1)[1].split()[0] == "R"
                except OSError:  # the thread ended
                    continue
            counts = self.samples[self.phase]
            counts[0] += 1
            counts[1] += runnable
            self.histogram[runnable] += 1
            time.sleep(SAMPLE_S)

    def stop(self) -> None:
        self._stop = True
        self._thread.join()

    def runnable(self, cores: int) -> dict:
        """Over every sample: the mean of min(runnable, ``cores``) (the cores a machine with nothing else
        running would keep busy; a shared machine's waiting threads still count) and the share of samples
        with fewer than ``cores`` runnable."""
        total = sum(self.histogram.values()) or 1
        return {
            "runnable_mean": sum(min(r, cores) * n for r, n in self.histogram.items()) / total,
            "share_below_cores": sum(n for r, n in self.histogram.items() if r < cores) / total,
        }


def passes(spec, fast, sampler: Sampler, bands: int) -> dict:
    """Plan and bake ``spec`` on ``fast``, kernel by kernel: {kernel: CPU s, runnable workers}."""
    program = fast.program
    launch, cpu = program.run, collections.Counter()

    def run(kernel, n_items, *args):
        program.queue.finish()
        sampler.phase, start = kernel.function_name, time.process_time()
        launch(kernel, n_items, *args)
        program.queue.finish()
        cpu[kernel.function_name] += time.process_time() - start
        sampler.phase = "host"

    program.run = run
    sampler.samples.clear()
    try:
        stats = fast.series_plan(spec)
        width, height = spec.image_size
        for y0, y1 in spec.row_chunks(-(-height // bands) * width):
            fast.begin_rows(spec, y0, y1).result()
    finally:
        del program.run  # the method again
    return {
        "cells": spec.cells,
        "closed_form_texels": stats.closed_form_texels,
        "kernels": {
            name: {"cpu_s": cpu[name], "workers_runnable": r / n, "samples": n}
            for name, (n, r) in sampler.samples.items()
            if name in cpu
        },
        "device_cpu_s": sum(cpu.values()),
    }


def main() -> None:
    from lutbake.integrate.opencl import OpenCLBackend
    from lutbake.lut.bake import default_specs

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--device", default="pocl-system")
    ap.add_argument("--bands", type=int, default=32)
    ap.add_argument("--json")
    args = ap.parse_args()
    fast = OpenCLBackend("float64", device=args.device)
    report = {"device": fast.device, "load_average_start": load_average(), "bands": args.bands, "luts": {}}
    sampler = Sampler()
    for name, spec in {"b1": _spec(1.5, B1_AXES), **default_specs()}.items():
        report["luts"][name] = passes(spec, fast, sampler, args.bands)
    sampler.stop()
    luts = [row for name, row in report["luts"].items() if name != "b1"]
    report["set_device_cpu_s_per_mcell"] = sum(r["device_cpu_s"] for r in luts) / sum(r["cells"] for r in luts) * 1e6
    report["b1_device_cpu_s_per_mcell"] = report["luts"]["b1"]["device_cpu_s"] / report["luts"]["b1"]["cells"] * 1e6
    # the closed form's passes: the plan's (its pole search, and its colours where the plan keeps them) and
    # the bake's (where the plan kept none)
    closed = ("plan_texels_closed", "bake_texels_closed")
    report["set_closed_form_share_of_device_cpu"] = sum(
        r["kernels"].get(name, {}).get("cpu_s", 0.0) for r in luts for name in closed
    ) / sum(r["device_cpu_s"] for r in luts)
    write_report(report, args.json)


if __name__ == "__main__":
    main()
