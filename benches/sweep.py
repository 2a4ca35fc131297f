"""Wall time of a 12-task sweep (two-spheres, 3 backends x 4 step counts) on a Dask
LocalCluster of 1 and of 2 single-threaded worker processes, and serially in this
process, in one sitting; the results are checked equal across the three.

    python benches/sweep.py

Needs `pip install '.[sweep]'`.
"""

import time

import distributed

import phyxel

TASKS = phyxel.grid(scene="two-spheres", backend=list(phyxel.BACKENDS), steps=[100, 200, 300, 400])


def timed(client):
    t0 = time.perf_counter()
    df = phyxel.sweep(TASKS, client=client)
    return time.perf_counter() - t0, df


def main():
    results = {}
    wall, df = timed(None)
    results["serial (this process)"] = (wall, df)
    for workers in (1, 2):
        with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
            with distributed.Client(cluster) as client:
                client.run(lambda: __import__("phyxel"))  # workers import phyxel before timing
                results[f"{workers} worker(s)"] = timed(client)
    keep = [c for c in df.columns if c.startswith("summary.") and not c.startswith(tuple(f"summary.{k}" for k in phyxel.WALL_KEYS))]
    reference = df[keep]
    for label, (wall, frame) in results.items():
        equal = frame[keep].equals(reference)
        print(f"{label:<22} {wall:6.2f} s   results equal to serial: {equal}")


if __name__ == "__main__":
    main()
