#!/usr/bin/python3
"""Times the Python module in a loop, as a script over many pairs runs it: the two bundled
KITTI pairs (sequence 00 scan 9 onto scan 0, 02 scan 6 onto scan 0) in turn, with
pcl_mi.align() (a new engine per call) or with one pcl_mi.Registration given each pair's
target (-reuse). Prints the median time and the median of fresh pages touched (minor page
faults) per alignment, the first six alignments left out. glibc's malloc thresholds move
both; see README's limits and docs/benchmarks.md, "How the process allocates".

usage: python_loop_time.py BUILD_DIR DATA_DIR [-reuse] [-alignments N]
e.g.   python_loop_time.py build data
       GLIBC_TUNABLES=glibc.malloc.mmap_threshold=33554432:glibc.malloc.trim_threshold=268435456 \\
           python_loop_time.py build data
"""
import resource
import sys
import time

try:
    import numpy as np
except ImportError:
    sys.exit("python_loop_time.py needs numpy: apt-get install python3-numpy (Debian's "
             "/usr/bin/python3, which this script's first line names, has it after "
             "scripts/setup_debian.sh)")


def main(argv):
    if len(argv) < 3 or argv[1] in ("-h", "--help"):
        sys.exit(__doc__)
    reuse = "-reuse" in argv[3:]
    alignments = int(argv[argv.index("-alignments") + 1]) if "-alignments" in argv else 40
    sys.path.insert(0, argv[1] + "/python")
    import pcl_mi

    def scan(sequence, frame):
        path = "%s/kitti/sequences/%s/velodyne/%06d.bin" % (argv[2], sequence, frame)
        return np.fromfile(path, dtype=np.float32).reshape(-1, 4)

    pairs = [(scan("00", 9), scan("00", 0)), (scan("02", 6), scan("02", 0))]
    registration = pcl_mi.Registration()
    seconds, faults, converged = [], [], 0
    for i in range(alignments):
        source, target = pairs[i % 2]
        before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        start = time.perf_counter()
        if reuse:
            registration.set_target(target)
            result = registration.align(source)
        else:
            result = pcl_mi.align(source, target)
        seconds.append(time.perf_counter() - start)
        faults.append(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
        converged += result.converged
    skip = min(6, alignments - 1)
    print("%s: %d alignments, %d converged; median %.1f ms, %d page faults per alignment" %
          ("one Registration" if reuse else "pcl_mi.align()", alignments, converged,
           1000 * np.median(seconds[skip:]), np.median(faults[skip:])))
    return 0 if converged == alignments else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
