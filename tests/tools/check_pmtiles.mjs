// Reads a PMTiles archive with the npm package `pmtiles` (not terrabake's
// reader) and checks it against the folder layout of the same layer:
//   node check_pmtiles.mjs ARCHIVE FOLDER EXTENSION
// EXTENSION names the folder's files the archive holds ("png", "glb",
// "elevation.png"). Every tile the folder has must come back from the archive
// with the same bytes, and the archive must address no other tile. The
// header and directories are walked as spec/v3/spec.md describes them:
// TileIDs ascending, every entry inside its section, the root directory
// within the first 16 KiB. Prints one line of JSON with what it counted;
// exits 1 with the first broken rule.
import fs from "node:fs";
import path from "node:path";
import zlib from "node:zlib";
import { PMTiles, bytesToHeader, tileIdToZxy, zxyToTileId } from "pmtiles";

const [archivePath, folder, extension] = process.argv.slice(2);
if (!extension) {
  console.error("usage: check_pmtiles.mjs ARCHIVE FOLDER EXTENSION");
  process.exit(2);
}

function fail(message) {
  console.error(`check_pmtiles: ${archivePath}: ${message}`);
  process.exit(1);
}

const file = fs.readFileSync(archivePath);
const fd = fs.openSync(archivePath, "r");
// A Source as the package defines it, over the local file.
const source = {
  getKey: () => archivePath,
  getBytes: async (offset, length) => {
    const buffer = Buffer.alloc(length);
    fs.readSync(fd, buffer, 0, length, offset);
    return { data: buffer.buffer.slice(buffer.byteOffset, buffer.byteOffset + length) };
  },
};
const archive = new PMTiles(source);
const header = await archive.getHeader();
const raw = bytesToHeader(file.buffer.slice(file.byteOffset, file.byteOffset + 127), undefined);
if (header.specVersion !== 3) fail(`spec version ${header.specVersion}`);
if (header.rootDirectoryOffset + header.rootDirectoryLength > 16384) fail("root directory beyond the first 16 KiB");
for (const [name, offset, length] of [
  ["root directory", header.rootDirectoryOffset, header.rootDirectoryLength],
  ["metadata", header.jsonMetadataOffset, header.jsonMetadataLength],
  ["leaf directories", header.leafDirectoryOffset, header.leafDirectoryLength],
  ["tile data", header.tileDataOffset, header.tileDataLength],
]) {
  if (offset < 127 || offset + length > file.length) fail(`${name} lies outside the file`);
}
if (raw.internalCompression !== 2) fail("directories are not gzip-compressed");
if (raw.tileCompression !== 1) fail("tiles are not marked as stored uncompressed");

// Directory decoding written from the spec (§4.2), not the package's.
function decodeDirectory(bytes) {
  const data = zlib.gunzipSync(bytes);
  let at = 0;
  const varint = () => {
    let value = 0n;
    let shift = 0n;
    for (;;) {
      if (at >= data.length) fail("a directory ends inside a varint");
      const byte = data[at++];
      value |= BigInt(byte & 0x7f) << shift;
      if (!(byte & 0x80)) return Number(value);
      shift += 7n;
    }
  };
  const n = varint();
  if (n <= 0) fail("a directory without entries");
  const entries = [];
  let id = 0;
  for (let i = 0; i < n; i++) entries.push({ tileId: (id += varint()) });
  for (const e of entries) e.runLength = varint();
  for (const e of entries) e.length = varint();
  for (let i = 0; i < n; i++) {
    const stored = varint();
    if (stored === 0 && i === 0) fail("the first entry of a directory has offset 0 (contiguous) encoded");
    entries[i].offset = stored === 0 ? entries[i - 1].offset + entries[i - 1].length : stored - 1;
  }
  if (at !== data.length) fail("bytes left after a directory");
  return entries;
}

const tileEntries = [];
let leaves = 0;
function walk(entries, depth) {
  for (let i = 1; i < entries.length; i++) {
    if (entries[i].tileId <= entries[i - 1].tileId) fail("TileIDs of a directory are not ascending");
  }
  for (const e of entries) {
    if (e.length <= 0) fail("an entry of length 0");
    if (e.runLength === 0) {
      if (depth > 0) fail("leaf directories nested below a leaf");
      if (e.offset + e.length > header.leafDirectoryLength) fail("a leaf directory lies outside its section");
      leaves++;
      const start = header.leafDirectoryOffset + e.offset;
      walk(decodeDirectory(file.subarray(start, start + e.length)), depth + 1);
    } else {
      if (e.offset + e.length > header.tileDataLength) fail("a tile lies outside the tile data");
      tileEntries.push(e);
    }
  }
}
const rootStart = header.rootDirectoryOffset;
walk(decodeDirectory(file.subarray(rootStart, rootStart + header.rootDirectoryLength)), 0);
for (let i = 1; i < tileEntries.length; i++) {
  const last = tileEntries[i - 1];
  if (tileEntries[i].tileId < last.tileId + last.runLength) fail("tile entries overlap or are out of order");
}

// Every tile of the folder, and its bytes through the package's getZxy.
const folderTiles = new Map();
let folderBytes = 0;
for (const z of fs.readdirSync(folder).filter((d) => /^\d+$/.test(d))) {
  for (const x of fs.readdirSync(path.join(folder, z))) {
    for (const name of fs.readdirSync(path.join(folder, z, x))) {
      const match = name.match(/^(\d+)\.(.+)$/);
      if (!match || match[2] !== extension) continue;
      const bytes = fs.readFileSync(path.join(folder, z, x, name));
      folderBytes += bytes.length;
      folderTiles.set(zxyToTileId(Number(z), Number(x), Number(match[1])), { z: +z, x: +x, y: +match[1], bytes });
    }
  }
}
let addressed = 0;
for (const e of tileEntries) {
  for (let id = e.tileId; id < e.tileId + e.runLength; id++) {
    addressed++;
    if (!folderTiles.has(id)) fail(`tile ${tileIdToZxy(id).join("/")} is in the archive, not in the folder`);
  }
}
for (const { z, x, y, bytes } of folderTiles.values()) {
  const answer = await archive.getZxy(z, x, y);
  if (!answer) fail(`tile ${z}/${x}/${y}.${extension} is missing`);
  if (!Buffer.from(answer.data).equals(bytes)) fail(`tile ${z}/${x}/${y}.${extension} differs from the folder's`);
}
if (addressed !== folderTiles.size) fail(`${addressed} tiles addressed, the folder has ${folderTiles.size}`);
if (header.numAddressedTiles !== addressed) fail("the header's count of addressed tiles is wrong");

const metadata = await archive.getMetadata();
console.log(
  JSON.stringify({
    tiles: folderTiles.size,
    entries: tileEntries.length,
    contents: header.numTileContents,
    leaves,
    tile_type: header.tileType,
    archive_bytes: file.length,
    folder_bytes: folderBytes,
    name: metadata.name,
  }),
);
