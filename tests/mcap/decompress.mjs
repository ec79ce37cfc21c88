// Chunk decompression for @mcap/core, from decoders independent of dca's (which uses Debian's libzstd and liblz4):
// fzstd (Zstandard in plain JavaScript) and lz4js (LZ4 frames in plain JavaScript), pinned in package-lock.json.
// Each checks that a chunk decompresses to exactly the size its record states.
import { open } from "node:fs/promises";
import { McapIndexedReader } from "@mcap/core";
import { decompress as zstd } from "fzstd";
import lz4js from "lz4js";

function sized(name, out, size) {
  if (BigInt(out.length) !== BigInt(size)) {
    throw new Error(`${name} chunk of ${out.length} bytes, not the ${size} its record states`);
  }
  return out;
}

export const decompressHandlers = {
  zstd: (buffer, size) => sized("zstd", zstd(buffer), size),
  lz4: (buffer, size) => sized("lz4", lz4js.decompress(buffer, Number(size)), size),
};

// FILE opened with @mcap/core's indexed reader (its summary read, chunks decompressed as above). --> { reader, handle }
export async function openIndexed(file) {
  const handle = await open(file, "r");
  const size = BigInt((await handle.stat()).size);
  const reader = await McapIndexedReader.Initialize({ readable: {
    size: async () => size,
    read: async (offset, length) => {
      const buf = new Uint8Array(Number(length));
      await handle.read(buf, 0, Number(length), Number(offset));
      return buf;
    },
  }, decompressHandlers });
  return { reader, handle };
}
