"""The X root window's pixels, from xwd's dump (tests on a virtual screen, under xvfb-run)."""
import struct
import subprocess


def grab_screen():
    """(width, height, bytes per line, BGRX pixels) of the X root window."""
    raw = subprocess.run(["xwd", "-root", "-silent"], capture_output=True, check=True).stdout
    header = struct.unpack(">25I", raw[:100])
    header_size, width, height, bytes_per_line, ncolors = (header[0], header[4], header[5],
                                                          header[12], header[19])
    return width, height, bytes_per_line, raw[header_size + 12 * ncolors:]


def count_pixels(screen, predicate, x_from=0.0, step=2):
    """How many sampled pixels (every `step`th) right of x_from·width satisfy predicate(r, g, b)."""
    width, height, bytes_per_line, pixels = screen
    count = 0
    for y in range(0, height, step):
        row = pixels[y * bytes_per_line:(y + 1) * bytes_per_line]
        for x in range(int(x_from * width), width, step):
            b, g, r = row[4 * x], row[4 * x + 1], row[4 * x + 2]
            if predicate(r, g, b):
                count += 1
    return count
