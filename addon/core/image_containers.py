# SPDX-License-Identifier: GPL-3.0-or-later
"""Header checks of the two sample formats whose headers point into the rest of the file, OpenEXR and
TIFF (used by image_headers); bpy-free. Each returns (width, height, channels) or calls fail()."""
import struct

from .image_limits import check_size

# ------------------------------------------------------------------------------------------ OpenEXR
# What OpenEXR may be made to allocate from one header: texsynth_image_io refuses more (kMaxExrHeaderBytes).
MAX_EXR_HEADER_BYTES = 64 << 20
_EXR_REQUIRED = {"channels": "chlist", "compression": "compression", "dataWindow": "box2i",
                 "displayWindow": "box2i", "lineOrder": "lineOrder", "pixelAspectRatio": "float",
                 "screenWindowCenter": "v2f", "screenWindowWidth": "float"}
_EXR_SIZES = {"compression": 1, "box2i": 16, "lineOrder": 1, "float": 4, "v2f": 8, "tiledesc": 9, "int": 4}
_EXR_LINES_PER_CHUNK = (1, 1, 1, 16, 32, 16, 32, 32, 32, 256)  # by compression: NONE .. DWAB
# Bounds on how much a header can make the walk below do (valid files stay far below them).
MAX_EXR_ATTRIBUTES, MAX_EXR_PARTS, MAX_EXR_CHUNKS = 4096, 1024, 1 << 20


def _printable(raw):
    text = "".join(chr(c) if 0x20 <= c < 0x7F else "?" for c in raw[:64])
    return text + "..." if len(raw) > 64 else text


def _exr_name(reader, offset, fail):
    """(name bytes, offset after its terminator); names are at most 255 bytes."""
    data = reader.at(offset, min(256, reader.size - offset), "OpenEXR header")
    end = data.find(b"\0")
    if end < 0:
        fail("OpenEXR header is cut short or holds an attribute name over 255 bytes: truncated or corrupt file")
    return data[:end], offset + end + 1


def _exr_header(reader, offset, declared, fail):
    """({name: (type, value bytes)}, offset after the header, bytes declared so far)."""
    attributes = {}
    while True:
        if len(attributes) > MAX_EXR_ATTRIBUTES:
            fail("OpenEXR header has more than %d attributes: corrupt file" % MAX_EXR_ATTRIBUTES)
        name, offset = _exr_name(reader, offset, fail)
        if not name:
            return attributes, offset, declared
        kind, offset = _exr_name(reader, offset, fail)
        size = struct.unpack("<i", reader.at(offset, 4, "OpenEXR header"))[0]
        offset += 4
        what = "OpenEXR header attribute '%s' (%s)" % (_printable(name), _printable(kind))
        if size < 0:
            fail("%s declares a negative size (%d): corrupt file" % (what, size))
        if size > reader.size - offset:
            fail("%s declares %d bytes but only %d bytes follow in the file: truncated or corrupt file"
                 % (what, size, reader.size - offset))
        declared += size
        if declared > MAX_EXR_HEADER_BYTES:
            fail("OpenEXR header declares more than %d MB of attributes (at attribute '%s', %d bytes): corrupt "
                 "file or not a texture sample" % (MAX_EXR_HEADER_BYTES >> 20, _printable(name), size))
        # Only the attributes read below are loaded; previews and ICC profiles are skipped.
        wanted = name.decode("latin-1") in _EXR_REQUIRED or name in (b"tiles", b"type", b"chunkCount")
        attributes[name.decode("latin-1")] = (kind.decode("latin-1"), reader.at(offset, size) if wanted else b"")
        offset += size


def _exr_channels(value, fail):
    count, at = 0, 0
    while True:
        end = value.find(b"\0", at)
        if end < 0:
            fail("OpenEXR channel list is malformed: corrupt file")
        if end == at:
            return count
        if end + 17 > len(value) or struct.unpack("<i", value[end + 1:end + 5])[0] not in (0, 1, 2):
            fail("OpenEXR channel list is malformed: corrupt file")
        count, at = count + 1, end + 17


def _levels(size, round_up):
    levels = 1
    while size > 1:
        size = (size + 1) // 2 if round_up else size // 2
        levels += 1
    return levels


def _level_size(size, level, round_up):
    return max(1, (size + (1 << level) - 1) >> level if round_up else size >> level)


def _exr_chunks(attributes, width, height, fail):
    """(chunks, bytes before a chunk's data size in its header) of one part."""
    if "tiles" not in attributes:
        compression = attributes["compression"][1][0]
        if compression >= len(_EXR_LINES_PER_CHUNK):
            fail("OpenEXR compression %d is unknown: corrupt file" % compression)
        return -(-height // _EXR_LINES_PER_CHUNK[compression]), 4
    tile_x, tile_y, mode = struct.unpack("<IIB", attributes["tiles"][1])
    level_mode, round_up = mode & 0xF, bool(mode >> 4 & 0xF)
    if tile_x < 1 or tile_y < 1 or level_mode > 2 or (mode >> 4) > 1:
        fail("OpenEXR tile description is invalid: corrupt file")
    tiles = lambda w, h: -(-w // tile_x) * -(-h // tile_y)  # noqa: E731
    if level_mode == 0:
        return tiles(width, height), 16
    if level_mode == 1:
        return sum(tiles(_level_size(width, level, round_up), _level_size(height, level, round_up))
                   for level in range(_levels(max(width, height), round_up))), 16
    return sum(tiles(_level_size(width, lx, round_up), _level_size(height, ly, round_up))
               for lx in range(_levels(width, round_up)) for ly in range(_levels(height, round_up))), 16


def check_exr(reader, fail):
    flags = struct.unpack("<I", reader.at(4, 4, "OpenEXR header"))[0]
    if flags & 0xFF != 2:
        fail("OpenEXR version %d is not supported: corrupt file" % (flags & 0xFF))
    if flags & 0x800:
        fail("deep OpenEXR files are not supported")
    multipart = bool(flags & 0x1000)
    parts, offset, declared = [], 8, 0
    while True:
        attributes, offset, declared = _exr_header(reader, offset, declared, fail)
        if not attributes:
            if not parts:
                fail("OpenEXR header has no attributes: corrupt file")
            break
        parts.append(attributes)
        if not multipart:
            break
        if len(parts) > MAX_EXR_PARTS:
            fail("OpenEXR file has more than %d parts: corrupt file" % MAX_EXR_PARTS)
    sizes, chunk_counts = [], []
    for attributes in parts:
        for name, kind in list(_EXR_REQUIRED.items()) + ([("tiles", "tiledesc")] if flags & 0x200 else []) + \
                ([("chunkCount", "int")] if multipart else []):
            if name not in attributes:
                fail("OpenEXR header has no '%s' attribute: corrupt file" % name)
            found, value = attributes[name]
            if found != kind or len(value) != _EXR_SIZES.get(kind, len(value)):
                fail("OpenEXR header attribute '%s' is not a %s: corrupt file" % (name, kind))
        if attributes.get("type", ("", b""))[1].startswith(b"deep"):
            fail("deep OpenEXR files are not supported")
        x_min, y_min, x_max, y_max = struct.unpack("<iiii", attributes["dataWindow"][1])
        width, height = x_max - x_min + 1, y_max - y_min + 1
        channels = _exr_channels(attributes["channels"][1], fail)
        check_size(width, height, channels, fail)
        count, size_at = _exr_chunks(attributes, width, height, fail)
        if multipart:
            count = struct.unpack("<i", attributes["chunkCount"][1])[0]
            if count < 1:
                fail("OpenEXR part declares %d chunks: corrupt file" % count)
        sizes.append((width, height, channels))
        chunk_counts.append(count)
    if sum(chunk_counts) > MAX_EXR_CHUNKS:
        fail("OpenEXR file declares %d chunks, more than %d: corrupt file or tiles too small for a sample"
             % (sum(chunk_counts), MAX_EXR_CHUNKS))
    # The offset tables follow the headers; every chunk they point at must lie inside the file.
    tables_end = offset + 8 * sum(chunk_counts)
    if tables_end > reader.size:
        fail("OpenEXR chunk offset table ends beyond the end of the file (%d bytes): truncated file" % reader.size)
    prefix = 4 if multipart else 0
    for part, count in enumerate(chunk_counts):
        table = reader.at(offset, 8 * count, "OpenEXR chunk offset table")
        offset += 8 * count
        size_at = prefix + (16 if "tiles" in parts[part] else 4)
        for chunk_offset in struct.unpack("<%dQ" % count, table):
            if chunk_offset < tables_end or chunk_offset + size_at + 4 > reader.size:
                fail("OpenEXR chunk offset %d lies outside the file (%d bytes): truncated or corrupt file"
                     % (chunk_offset, reader.size))
            data_size = struct.unpack("<i", reader.at(chunk_offset + size_at, 4))[0]
            if data_size < 0 or chunk_offset + size_at + 4 + data_size > reader.size:
                fail("OpenEXR chunk at byte %d ends beyond the end of the file (%d bytes): truncated file"
                     % (chunk_offset, reader.size))
    return sizes[0]


# ------------------------------------------------------------------------------------------ TIFF
_TIFF_TYPE_SIZES = {1: 1, 2: 1, 3: 2, 4: 4, 5: 8, 6: 1, 7: 1, 8: 2, 9: 4, 10: 8, 11: 4, 12: 8, 13: 4,
                    16: 8, 17: 8, 18: 8}
MAX_TIFF_ENTRIES = 4096
_TIFF_INTEGERS = {1: "B", 3: "H", 4: "I", 6: "b", 8: "h", 9: "i", 13: "I", 16: "Q", 17: "q", 18: "Q"}


def check_tiff(reader, fail):
    head = reader.at(0, 8, "TIFF header")
    order = "<" if head[:2] == b"II" else ">"
    big = struct.unpack(order + "H", head[2:4])[0] == 43
    if big:
        byte_size, zero, directory = struct.unpack(order + "HHQ", reader.at(4, 12, "TIFF header"))
        if byte_size != 8 or zero != 0:
            fail("BigTIFF header is malformed: corrupt file")
    else:
        directory = struct.unpack(order + "I", head[4:8])[0]
    count_format, entry_size, inline, offset_format = ("Q", 20, 8, "Q") if big else ("H", 12, 4, "I")
    if directory < 8 or directory >= reader.size:
        fail("TIFF directory offset %d lies outside the file (%d bytes): truncated or corrupt file"
             % (directory, reader.size))
    count_size = struct.calcsize(count_format)
    count = struct.unpack(order + count_format, reader.at(directory, count_size, "TIFF directory"))[0]
    if count == 0 or count > MAX_TIFF_ENTRIES:  # libtiff's own sanity limit
        fail("TIFF directory declares %d entries: corrupt file" % count)
    if directory + count_size + count * entry_size + inline > reader.size:
        fail("TIFF directory of %d entries does not fit in the file: truncated or corrupt file" % count)
    entries = reader.at(directory + count_size, count * entry_size + inline, "TIFF directory")
    tags = {}
    for index in range(count):
        entry = entries[index * entry_size:(index + 1) * entry_size]
        tag, kind = struct.unpack(order + "HH", entry[:4])
        number = struct.unpack(order + offset_format, entry[4:4 + inline])[0]
        field = entry[4 + inline:]
        if kind not in _TIFF_TYPE_SIZES:
            continue  # libtiff skips tags of unknown types
        length = number * _TIFF_TYPE_SIZES[kind]
        if length > inline:
            at = struct.unpack(order + offset_format, field)[0]
            if at + length > reader.size:
                fail("TIFF tag %d declares %d bytes at byte %d, beyond the end of the file (%d bytes): truncated "
                     "or corrupt file" % (tag, length, at, reader.size))
            tags[tag] = (kind, number, at)
        else:
            tags[tag] = (kind, number, field[:length])
    following = struct.unpack(order + offset_format, entries[-inline:])[0]
    if following and (following < 8 or following >= reader.size):
        fail("TIFF next directory offset %d lies outside the file: truncated or corrupt file" % following)

    def values(tag, default=None, limit=1):
        """The tag's first `limit` integers (a huge declared count is never loaded whole)."""
        if tag not in tags:
            return default
        kind, number, where = tags[tag]
        number = min(number, limit)
        if kind not in _TIFF_INTEGERS:
            fail("TIFF tag %d has a non-integer type (%d): corrupt file" % (tag, kind))
        data = where[:number * _TIFF_TYPE_SIZES[kind]] if isinstance(where, bytes) else \
            reader.at(where, number * _TIFF_TYPE_SIZES[kind])
        return list(struct.unpack(order + "%d%s" % (number, _TIFF_INTEGERS[kind]), data))

    width, height = (values(256) or [0])[0], (values(257) or [0])[0]
    channels = (values(277, [1]) or [1])[0]
    if (values(262, [-1]) or [-1])[0] == 5:
        fail("CMYK TIFF samples are not supported (save the sample as RGB)")
    check_size(width, height, channels, fail)
    planes = channels if (values(284, [1]) or [1])[0] == 2 else 1
    if 322 in tags:
        tile_w, tile_h = (values(322) or [0])[0], (values(323, [0]) or [0])[0]
        if tile_w < 1 or tile_h < 1:
            fail("TIFF tile size %dx%d is invalid: corrupt file" % (tile_w, tile_h))
        pieces = -(-width // tile_w) * -(-height // tile_h) * planes
        offsets, counts = values(324, None, pieces), values(325, None, pieces)
    else:
        rows = max(1, min((values(278, [height]) or [height])[0], height))
        pieces = -(-height // rows) * planes
        offsets, counts = values(273, None, pieces), values(279, None, pieces)
    if offsets is None or len(offsets) < pieces or (counts is not None and len(counts) < pieces):
        fail("TIFF file lists fewer image data blocks than its size needs (%d): corrupt file" % pieces)
    for index in range(pieces):
        end = offsets[index] + (counts[index] if counts is not None else 1)
        if offsets[index] < 0 or end > reader.size:
            fail("TIFF image data block %d ends beyond the end of the file (%d bytes): truncated file"
                 % (index, reader.size))
    return width, height, channels
