# The hand-made reproducers of issue 45 kept under tests/fuzz/cases/ (see README.md there):
# python3 tests/fuzz/cases/issue45_cases.py tests/fuzz/cases BAND_TOML, where BAND_TOML holds
# the band_toml seed of tests/fuzz/decoders.rs. Needs numpy and Pillow (for the TIFF).
import struct, zlib, os, sys
root = sys.argv[1]
def put(target, name, data):
    d = os.path.join(root, target); os.makedirs(d, exist_ok=True)
    open(os.path.join(d, name), 'wb').write(data)

def npy(shape, descr, raw, version=1, fortran=False):
    t = "(%s,)" % shape[0] if len(shape) == 1 else "(%s)" % ", ".join(map(str, shape))
    h = "{'descr': '%s', 'fortran_order': %s, 'shape': %s, }" % (descr, "True" if fortran else "False", t)
    pre = 10 if version == 1 else 12
    while (pre + len(h) + 1) % 64: h += ' '
    h += '\n'
    out = b'\x93NUMPY' + bytes([version, 0])
    out += struct.pack('<H' if version == 1 else '<I', len(h)) + h.encode()
    return out + raw

# .npy: a 3 GB array declared, 16 bytes stored; a shape whose bytes wrap usize (2^62 x 4 = 2^64);
# a header length of 4 GiB - 1 (version 2); a dimension of 2^64 - 1.
put('npy', 'issue45-3gb-declared.npy', npy([3000000000], '|u1', bytes(16)))
put('npy', 'issue45-bytes-wrap-2pow64.npy', npy([2097152, 2097152, 1048576], '<f4', b''))
put('npy', 'issue45-shape-2pow64-1.npy', npy([18446744073709551615, 1], '<f4', bytes(8)))
v2 = bytearray(npy([2, 2], '<f4', bytes(16), version=2)); v2[8:12] = struct.pack('<I', 0xFFFFFFFF)
put('npy', 'issue45-header-4gib.npy', bytes(v2))

def el(ty, data, pad=True):
    out = struct.pack('<II', ty, len(data)) + data
    if pad: out += bytes((-len(out)) % 8)
    return out
def matrix(name, dims, cls, storage, raw, nvalues=None):
    body = el(6, struct.pack('<II', cls, 0)) + el(5, b''.join(struct.pack('<i', d) for d in dims))
    body += el(1, name.encode())
    n = len(raw) if nvalues is None else nvalues
    body += struct.pack('<II', storage, n) + raw + bytes((-len(raw)) % 8)
    return struct.pack('<II', 14, len(body)) + body
def mat(elements):
    h = b"MATLAB 5.0 MAT-file, femto issue 45".ljust(116, b' ') + bytes(8) + struct.pack('<H', 0x100) + b'IM'
    return h + b''.join(elements)
def z(m):
    c = zlib.compress(m)
    return struct.pack('<II', 15, len(c)) + c

# MATLAB v5: 2^62 single values declared, none stored (plain and compressed); a compressed
# element whose inner matrix declares 1.2 GB of uint8 but holds 64 kB (the bomb's header);
# a values tag of 4 GiB - 1 bytes; a small element claiming 65535 bytes; a dimension of -1.
huge = matrix('huge', [2097152, 2097152, 1048576], 7, 7, b'')
put('mat', 'issue45-2pow62-no-values.mat', mat([huge]))
put('mat', 'issue45-2pow62-no-values-z.mat', mat([z(huge)]))
bomb_head = matrix('bomb', [1000, 1000, 1200], 9, 2, bytes(65536), nvalues=1200000000)
bomb_head = struct.pack('<II', 14, 1200000000 + 64) + bomb_head[8:]
put('mat', 'issue45-bomb-header.mat', mat([z(bomb_head)]))
put('mat', 'issue45-values-4gib.mat', mat([matrix('v', [2, 2], 6, 9, bytes(32), nvalues=0xFFFFFFFF)]))
small = bytearray(matrix('s', [1, 1], 6, 9, struct.pack('<d', 0.5)))
i = small.index(b's') - 4; small[i - 4:i] = struct.pack('<I', (0xFFFF << 16) | 1)
put('mat', 'issue45-small-element-65535.mat', mat([bytes(small)]))
put('mat', 'issue45-negative-dimension.mat', mat([matrix('n', [-1, 4], 6, 9, bytes(32))]))

# HPD-TA .img: areSource y offset 2^64 - 1; a table count of 2^62; a table offset of 2^64 - 1.
def img(y, count, offset=None, w=16, h=8):
    def comment(off):
        return ('[Application],Software="HPD-TA"\r\n[Acquisition],areSource="0,%s,%d,%d"\r\n'
                '[Streak camera],Mode="Operate"\r\n[Scaling],ScalingXType=1,ScalingXScale=1,'
                'ScalingXUnit="px",ScalingYType=2,ScalingYUnit="ps",ScalingYScalingFile="#%012d,%s"\r\n'
                % (y, w, h, off, count))
    at = 64 + len(comment(0)) + 2 * w * h
    c = comment(at if offset is None else offset)
    out = b'IM' + struct.pack('<hhhhhh', len(c), w, h, 0, 0, 2) + struct.pack('<i', 0)
    out = out.ljust(64, b'\0') + c.encode()
    out += b''.join(struct.pack('<H', i % 4000) for i in range(w * h))
    out += b''.join(struct.pack('<f', 100 + 2 * i) for i in range(h + 8))
    return out
put('img', 'issue45-aresource-y-2pow64-1.img', img('18446744073709551615', '16'))
put('img', 'issue45-table-count-2pow62.img', img('0', '4611686018427387904'))
put('img', 'issue45-table-offset-2pow64-1.img', img('0', '16', offset=18446744073709551615 % 10**12))

# band.toml: rows past 2^64 and a band of 2^64 - 1 rows.
band = open(sys.argv[2]).read()
put('band_toml', 'issue45-rows-end-2pow64-1.toml', band.replace('rows_end = 8', 'rows_end = 18446744073709551615').encode())
put('band_toml', 'issue45-ny-2pow64-1.toml', band.replace('ny = 8', 'ny = 18446744073709551615').replace('rows_end = 8', 'rows_end = 18446744073709551615').encode())

def img2(y, count, offset_text, w=16, h=8):
    c = ('[Application],Software="HPD-TA"\r\n[Acquisition],areSource="0,%s,%d,%d"\r\n'
         '[Streak camera],Mode="Operate"\r\n[Scaling],ScalingXType=1,ScalingXScale=1,'
         'ScalingXUnit="px",ScalingYType=2,ScalingYUnit="ps",ScalingYScalingFile="#%s,%s"\r\n'
         % (y, w, h, offset_text, count))
    out = b'IM' + struct.pack('<hhhhhh', len(c), w, h, 0, 0, 2) + struct.pack('<i', 0)
    out = out.ljust(64, b'\0') + c.encode()
    out += b''.join(struct.pack('<H', i % 4000) for i in range(w * h))
    out += b''.join(struct.pack('<f', 100 + 2 * i) for i in range(h + 8))
    return out, c
data, _ = img2('0', '16', '18446744073709551615')
put('img', 'issue45-table-offset-2pow64-1.img', data)

# HPD-TA TIFF: the same comments in a 16-bit TIFF's ImageDescription (Pillow).
from PIL import Image, TiffImagePlugin
import io, numpy as np
def tif(comment):
    a = (np.arange(16 * 8) % 4000).astype('<u2').reshape(8, 16)
    im = Image.fromarray(a)
    info = TiffImagePlugin.ImageFileDirectory_v2(); info[270] = comment
    b = io.BytesIO(); im.save(b, format='TIFF', tiffinfo=info); return b.getvalue()
for name, y, count, off in [('aresource-y-2pow64-1', '18446744073709551615', '16', '8'),
                            ('table-count-2pow62', '0', '4611686018427387904', '8'),
                            ('table-offset-2pow64-1', '0', '16', '18446744073709551615')]:
    _, c = img2(y, count, off)
    put('hpd_tiff', 'issue45-%s.tif' % name, tif(c))

# EXR: a scanline RGB float frame of 8 x 6 written by hand, then one whose data window claims
# 16777216 x 1048576 pixels (the frame of `femto compare` that asked 211 TB).
def attr(name, ty, data): return name.encode() + b'\0' + ty.encode() + b'\0' + struct.pack('<i', len(data)) + data
def exr(w, h, claim=None):
    ch = b''.join(c.encode() + b'\0' + struct.pack('<iB3xii', 2, 0, 1, 1) for c in 'BGR') + b'\0'
    cw, chh = claim or (w, h)
    hdr = (attr('channels', 'chlist', ch) + attr('compression', 'compression', b'\0')
           + attr('dataWindow', 'box2i', struct.pack('<4i', 0, 0, cw - 1, chh - 1))
           + attr('displayWindow', 'box2i', struct.pack('<4i', 0, 0, w - 1, h - 1))
           + attr('lineOrder', 'lineOrder', b'\0') + attr('pixelAspectRatio', 'float', struct.pack('<f', 1))
           + attr('screenWindowCenter', 'v2f', struct.pack('<2f', 0, 0)) + attr('screenWindowWidth', 'float', struct.pack('<f', 1))
           + b'\0')
    start = 8 + len(hdr) + 8 * h
    line = 8 + 3 * 4 * w
    offsets = b''.join(struct.pack('<Q', start + y * line) for y in range(h))
    lines = b''.join(struct.pack('<ii', y, 3 * 4 * w) + struct.pack('<%df' % (3 * w), *([0.25] * 3 * w)) for y in range(h))
    return b'\x76\x2f\x31\x01' + struct.pack('<I', 2) + hdr + offsets + lines
put('exr_frame', 'issue45-valid-8x6.exr', exr(8, 6))
put('exr_frame', 'issue45-window-16777216x1048576.exr', exr(8, 6, (16777216, 1048576)))
put('exr_frame', 'issue45-window-2pow31.exr', exr(8, 6, (2**31 - 1, 2**31 - 1)))

# The other values of the list (0, 2^31, 2^32) where a header count meets `*`.
put('npy', 'issue45-shape-0.npy', npy([0, 4], '<f4', b''))
put('npy', 'issue45-shape-2pow31.npy', npy([2**31], '<f4', bytes(16)))
put('npy', 'issue45-shape-2pow32.npy', npy([2**32, 2], '<f8', bytes(16)))
put('mat', 'issue45-dims-0.mat', mat([matrix('z', [0, 4, 3], 6, 9, b'')]))
put('mat', 'issue45-dims-2pow31-1.mat', mat([matrix('m', [2**31 - 1, 2**31 - 1, 2], 6, 9, bytes(64))]))
for count, tag in [('0', '0'), ('2147483648', '2pow31'), ('4294967296', '2pow32')]:
    data, c = img2('0', count, '600')
    put('img', 'issue45-table-count-%s.img' % tag, data)
    put('hpd_tiff', 'issue45-table-count-%s.tif' % tag, tif(c))
put('exr_frame', 'issue45-window-2pow32.exr', exr(8, 6, (65536, 65536)))
