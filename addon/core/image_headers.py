# SPDX-License-Identifier: GPL-3.0-or-later
"""A sample file's header read and checked before Blender opens it; bpy-free.

The self-contained package has no OpenImageIO, so Blender decodes the sample, and Blender 3.4's OpenEXR
reader never returns on a 20-byte cut of a valid file (the hostile corpus's truncated_header.exr). So
the format comes from the leading bytes, the size from the header (the native pixel limits), and every
offset or length the header declares must lie inside the file; anything else is refused with one line,
worded like texsynth_image_io's sniffing. Reads and loops are bounded by the file's size and fixed
limits, so no input makes the check run long or allocate much."""
import collections
import io
import os
import re
import struct
import zlib

from .image_containers import check_exr, check_tiff
from .image_limits import HeaderError, check_size

Header = collections.namedtuple("Header", "format width height channels")

SUPPORTED = "PNG, JPEG, OpenEXR, TIFF, BMP, Radiance HDR, WebP or TGA"


class FileReader:
    """Bounded reads from an open file; reading past its end is a truncation error."""

    def __init__(self, handle, size, fail):
        self.handle, self.size, self.fail = handle, size, fail

    def at(self, offset, length, what="header"):
        if offset < 0 or length < 0 or offset + length > self.size:
            self.fail("%s ends beyond the end of the file (%d bytes): truncated or corrupt file" % (what, self.size))
        self.handle.seek(offset)
        data = self.handle.read(length)
        if len(data) != length:
            self.fail("%s cannot be read: truncated file" % what)
        return data

    def find(self, needle, start, chunk=1 << 20):
        """Offset of the first `needle` at or after `start`, or -1 (chunked: big files are not loaded)."""
        self.handle.seek(start)
        tail, base = b"", start
        while True:
            data = self.handle.read(chunk)
            if not data:
                return -1
            found = (tail + data).find(needle)
            if found >= 0:
                return base - len(tail) + found
            tail = (tail + data)[-(len(needle) - 1):]
            base += len(data)


def check_sample_file(path):
    """Header(format, width, height, channels) of a sample file Blender may open, or HeaderError."""
    if not path:
        raise HeaderError("image path is empty")

    def fail(what):
        raise HeaderError("image '%s': %s" % (path, what))

    if not os.path.exists(path):
        fail("file does not exist")
    if os.path.isdir(path):
        fail("is a directory, not an image file")
    if not os.path.isfile(path):
        fail("is not a regular file")
    try:
        with open(path, "rb") as handle:
            return _check(path, handle, os.fstat(handle.fileno()).st_size)
    except OSError as error:
        fail("file cannot be read (%s)" % (error.strerror or error))


def check_sample_data(data, path):
    """check_sample_file on bytes already in memory (named `path` in messages and for TGA's extension)."""
    return _check(path, io.BytesIO(data), len(data))


def _check(path, handle, size):
    def fail(what):
        raise HeaderError("image '%s': %s" % (path, what))

    if size == 0:
        fail("file is empty (0 bytes)")
    reader = FileReader(handle, size, fail)
    head = reader.at(0, min(size, 16))
    if head.startswith(b"\x89PNG\r\n\x1a\n"):
        return _png(reader, fail)
    if head.startswith(b"\xff\xd8\xff"):
        return _jpeg(reader, fail)
    if head.startswith(b"\x76\x2f\x31\x01"):
        return Header("openexr", *check_exr(reader, fail))
    if head[:4] in (b"II*\0", b"MM\0*", b"II+\0", b"MM\0+"):
        return Header("tiff", *check_tiff(reader, fail))
    if head.startswith(b"BM"):
        return _bmp(reader, fail)
    if head.startswith(b"#?"):
        return _hdr(reader, fail)
    if len(head) >= 2 and head[:1] == b"P" and head[1:2] in b"123456fF":
        fail("PNM/PFM samples cannot be read inside Blender (save the sample as PNG or OpenEXR)")
    if head.startswith(b"RIFF") and head[8:12] == b"WEBP":
        return _webp(reader, fail)
    if head.startswith(b"GIF8"):
        fail("GIF samples are not supported (convert the image to PNG)")
    if os.path.splitext(path)[1].lower() in (".tga", ".tpic"):
        return _tga(reader, fail)
    fail("not a supported image format (%s)" % SUPPORTED)


# ------------------------------------------------------------------------------------------ PNG
_PNG_DEPTHS = {0: (1, 2, 4, 8, 16), 2: (8, 16), 3: (1, 2, 4, 8), 4: (8, 16), 6: (8, 16)}
_PNG_CHANNELS = {0: 1, 2: 3, 3: 3, 4: 2, 6: 4}
MAX_PNG_CHUNKS = 1 << 20  # libpng writes 8 kB data chunks: an 8K 16-bit RGBA sample has 60,000 at most


def _png(reader, fail):
    ihdr = reader.at(8, 25, "PNG header")
    length, kind = struct.unpack(">I4s", ihdr[:8])
    if kind != b"IHDR" or length != 13:
        fail("PNG file does not start with its IHDR header: corrupt file")
    if struct.unpack(">I", ihdr[21:25])[0] != zlib.crc32(ihdr[4:21]):
        fail("PNG header (IHDR) fails its checksum: corrupt file")
    width, height, depth, colour, compression, filtering, interlace = struct.unpack(">IIBBBBB", ihdr[8:21])
    if depth not in _PNG_DEPTHS.get(colour, ()) or compression or filtering or interlace > 1:
        fail("PNG header declares an invalid format (colour type %d, %d bits): corrupt file" % (colour, depth))
    check_size(width, height, _PNG_CHANNELS[colour], fail)
    # Every chunk must lie inside the file, up to IEND: a cut file is refused before any decoding.
    offset, seen = 33, set()
    for _ in range(MAX_PNG_CHUNKS):
        length, kind = struct.unpack(">I4s", reader.at(offset, 8, "PNG chunk"))
        if length > 0x7FFFFFFF or not kind.isalpha():
            fail("PNG chunk at byte %d is malformed: corrupt file" % offset)
        if offset + 12 + length > reader.size:
            fail("PNG chunk %s at byte %d ends beyond the end of the file: truncated or corrupt file"
                 % (kind.decode("ascii"), offset))
        if kind == b"IEND":
            break
        seen.add(kind)
        offset += 12 + length
    else:
        fail("PNG file has more than %d chunks: corrupt file" % MAX_PNG_CHUNKS)
    if b"IDAT" not in seen or (colour == 3 and b"PLTE" not in seen):
        fail("PNG file has no image data (IDAT%s): corrupt file" % (" or PLTE" if colour == 3 else ""))
    return Header("png", width, height, _PNG_CHANNELS[colour])


# ------------------------------------------------------------------------------------------ JPEG
MAX_JPEG_MARKERS = 1 << 16
def _jpeg(reader, fail):
    offset, frame = 2, None
    for _ in range(MAX_JPEG_MARKERS):
        marker = reader.at(offset, 2, "JPEG marker")
        if marker[0] != 0xFF:
            fail("JPEG marker expected at byte %d: corrupt file" % offset)
        if marker[1] == 0xFF:  # fill byte
            offset += 1
            continue
        code = marker[1]
        if 0xD0 <= code <= 0xD8 or code == 0x01:  # no length
            offset += 2
            continue
        if code == 0xD9:
            fail("JPEG file ends before its image data: corrupt file")
        length = struct.unpack(">H", reader.at(offset + 2, 2, "JPEG segment"))[0]
        if length < 2:
            fail("JPEG segment at byte %d has an invalid length: corrupt file" % offset)
        segment = reader.at(offset + 4, length - 2, "JPEG segment")
        if 0xC0 <= code <= 0xCF and code not in (0xC4, 0xC8, 0xCC):
            if len(segment) < 6:
                fail("JPEG frame header is too short: corrupt file")
            _, height, width, components = struct.unpack(">BHHB", segment[:6])
            if height == 0:
                fail("JPEG files whose height follows the image data (DNL) are not supported")
            if components not in (1, 3, 4):
                fail("JPEG frame declares %d components: corrupt file" % components)
            frame = (width, height, components)
        if code == 0xDA:
            break
        offset += 2 + length
    else:
        fail("JPEG file has more than %d markers before its image data: corrupt file" % MAX_JPEG_MARKERS)
    if frame is None:
        fail("JPEG file has image data but no frame header: corrupt file")
    check_size(frame[0], frame[1], min(frame[2], 3), fail)
    # Entropy-coded data never holds FF D9 (an FF in it is followed by 00 or a restart marker).
    if reader.find(b"\xff\xd9", offset + 2 + length) < 0:
        fail("JPEG file has no end marker (FF D9): truncated file")
    return Header("jpeg", frame[0], frame[1], min(frame[2], 3))


# ------------------------------------------------------------------------------------------ BMP
def _bmp(reader, fail):
    head = reader.at(0, 26, "BMP header")
    data_offset, info_size = struct.unpack("<I I", head[10:18])
    if info_size == 12:
        width, height, planes, bits = struct.unpack("<HHHH", head[18:26])
        compression = 0
    elif info_size in (40, 52, 56, 64, 108, 124):
        width, height, planes, bits, compression = struct.unpack("<iiHHI", reader.at(18, 16, "BMP header"))
    else:
        fail("BMP header size %d is not a known version: corrupt file" % info_size)
    if planes != 1 or bits not in (1, 2, 4, 8, 16, 24, 32):
        fail("BMP header declares %d planes of %d bits: corrupt file" % (planes, bits))
    if compression in (4, 5):
        fail("BMP files holding a JPEG or PNG are not supported (save the sample as PNG)")
    if compression not in (0, 1, 2, 3, 6):
        fail("BMP compression %d is not supported: corrupt file" % compression)
    channels = 4 if bits == 32 else 3
    check_size(width, abs(height), channels, fail)
    if data_offset < 14 + info_size or data_offset >= reader.size:
        fail("BMP pixel data offset %d lies outside the file (%d bytes): truncated or corrupt file"
             % (data_offset, reader.size))
    if compression in (0, 3, 6):
        row = (width * bits + 31) // 32 * 4
        if data_offset + row * abs(height) > reader.size:
            fail("BMP pixel data needs %d bytes but the file has %d after the header: truncated file"
                 % (row * abs(height), reader.size - data_offset))
    return Header("bmp", width, abs(height), channels)


# ------------------------------------------------------------------------------------------ TGA
def _tga(reader, fail):
    head = reader.at(0, 18, "TGA header")
    id_length, map_type, kind, _, map_length, map_bits, _, _, width, height, bits, _ = struct.unpack(
        "<BBBHHBHHHHBB", head)
    if map_type not in (0, 1) or kind not in (1, 2, 3, 9, 10, 11) or bits not in (8, 15, 16, 24, 32) \
            or (kind in (1, 9)) != (map_type == 1) or (map_type == 1 and map_bits not in (15, 16, 24, 32)):
        fail("not a valid TGA header (colour map %d, type %d, %d bits): corrupt file or not a TGA"
             % (map_type, kind, bits))
    channels = 1 if kind in (3, 11) else (4 if bits == 32 or (map_type and map_bits == 32) else 3)
    check_size(width, height, channels, fail)
    start = 18 + id_length + (map_length * ((map_bits + 7) // 8) if map_type else 0)
    per_pixel = (bits + 7) // 8
    # Raw data holds every pixel; a run-length packet covers at most 128 pixels in 1 + per_pixel bytes.
    need = width * height * per_pixel if kind < 9 else -(-width * height // 128) * (1 + per_pixel)
    if start + need > reader.size:
        fail("TGA pixel data needs at least %d bytes but the file has %d after the header: truncated file"
             % (need, max(0, reader.size - start)))
    return Header("targa", width, height, channels)


# ------------------------------------------------------------------------------------------ Radiance HDR
_HDR_SIZE = re.compile(rb"([-+])([XY]) (\d{1,9}) ([-+])([XY]) (\d{1,9})")


def _hdr(reader, fail):
    text = reader.at(0, min(reader.size, 65536), "Radiance header")
    end = text.find(b"\n\n")
    if end < 0:
        fail("Radiance HDR header has no end (no blank line in its first 64 kB): truncated or corrupt file")
    for line in text[:end].split(b"\n"):
        if line.startswith(b"FORMAT=") and line[7:].strip() not in (b"32-bit_rle_rgbe", b"32-bit_rle_xyze"):
            fail("Radiance HDR format %r is not supported" % line[7:].strip().decode("latin-1"))
    line_end = text.find(b"\n", end + 2)
    match = _HDR_SIZE.fullmatch(text[end + 2:line_end].strip()) if line_end > 0 else None
    if match is None or match.group(2) == match.group(5):
        fail("Radiance HDR resolution line is missing or malformed: truncated or corrupt file")
    first, second = int(match.group(3)), int(match.group(6))
    width, height = (second, first) if match.group(2) == b"Y" else (first, second)
    check_size(width, height, 3, fail)
    if reader.size - (line_end + 1) < 4 * height:  # every scanline takes 4 bytes at least
        fail("Radiance HDR pixel data is shorter than %d scanlines: truncated file" % height)
    return Header("hdr", width, height, 3)


# ------------------------------------------------------------------------------------------ WebP
def _webp(reader, fail):
    riff_size = struct.unpack("<I", reader.at(4, 4, "WebP header"))[0]
    if riff_size + 8 > reader.size:
        fail("WebP file declares %d bytes but has %d: truncated file" % (riff_size + 8, reader.size))
    kind, length = struct.unpack("<4sI", reader.at(12, 8, "WebP chunk"))
    body = reader.at(20, min(length, 30), "WebP chunk")
    if kind == b"VP8X" and len(body) >= 10:
        width = 1 + int.from_bytes(body[4:7], "little")
        height = 1 + int.from_bytes(body[7:10], "little")
    elif kind == b"VP8L" and len(body) >= 5 and body[0] == 0x2F:
        bits = int.from_bytes(body[1:5], "little")
        width, height = 1 + (bits & 0x3FFF), 1 + ((bits >> 14) & 0x3FFF)
    elif kind == b"VP8 " and len(body) >= 10 and body[3:6] == b"\x9d\x01\x2a":
        width, height = (v & 0x3FFF for v in struct.unpack("<HH", body[6:10]))
    else:
        fail("WebP file has no valid image chunk (VP8, VP8L or VP8X): corrupt file")
    if 20 + length > reader.size:
        fail("WebP chunk %s ends beyond the end of the file: truncated file" % kind.decode("latin-1").strip())
    check_size(width, height, 4, fail)
    return Header("webp", width, height, 4)
