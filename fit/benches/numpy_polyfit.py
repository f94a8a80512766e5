"""numpy.polyfit side of the `streaming` benchmark (fit/benches/streaming.rs).

Usage: python3 numpy_polyfit.py DATA.npy DEGREE

DATA.npy holds a (2, N) float64 array: the x row, then the y row. The script times
loading (memory-mapped) plus numpy.polyfit(x, y, DEGREE) and prints
`key=value` lines: seconds, peak RSS (ru_maxrss, KiB), the RSS right after
importing numpy (baseline), and the coefficients in ascending order.
Exit status 3 means numpy is not installed.
"""

import resource
import sys
import time


def vm_rss_kib():
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return -1


def main():
    try:
        import numpy as np
    except ImportError:
        print("error=numpy is not installed; install it with: pip install numpy")
        sys.exit(3)
    path, degree = sys.argv[1], int(sys.argv[2])
    baseline = vm_rss_kib()
    start = time.perf_counter()
    data = np.load(path, mmap_mode="r")
    x = data[0]
    y = data[1]
    coeffs = np.polyfit(x, y, degree)
    seconds = time.perf_counter() - start
    print(f"numpy_version={np.__version__}")
    print(f"seconds={seconds!r}")
    print(f"peak_rss_kib={resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}")
    print(f"baseline_rss_kib={baseline}")
    print("coeffs=" + ",".join(repr(float(c)) for c in coeffs[::-1]))


if __name__ == "__main__":
    main()
