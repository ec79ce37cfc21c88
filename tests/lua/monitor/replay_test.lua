-- dca.monitor.replay through the recording's index (docs/monitor.md, "Replay"): opening a long recording reads
-- its summary and the chunks that hold the run's lines and each channel's first message, not every chunk; a
-- signal's rows are read chunk by chunk when the page asks for them, equal to the messages of the file.
local T = require "dca.testing"
local suite = T.suite("monitor_replay")

local core = require "dca.core"
local replay = require "dca.monitor.replay"

-- A recording of N samples of /world/sig every 10 ms between the run's first and last lines. --> its path
local function recording(n)
  local file = T.tmpname(".mcap")
  local w = assert(core.mcap_writer(file))
  local events = w:channel("/dca/events", "dca/events", '{"type":"object"}')
  local sig = w:channel("/world/sig", "/world/sig", '{"type":"object"}')
  w:write(events, '{"line":"main.a: running","path":"main.a","state":"running"}', 0)
  for i = 1, n do
    w:write(sig, string.format('{"x":%d,"y":[%d,%d],"pad":"%s"}', i, 2 * i, 3 * i, ("p"):rep(60)), i * 10000000)
  end
  w:write(events, '{"line":"main: DONE","path":"main","state":"DONE"}', (n + 1) * 10000000)
  assert(w:finish())
  return file
end

suite:case("opening_reads_the_lines_chunks_not_every_chunk_and_rows_come_chunk_by_chunk", function()
  local file = recording(20000)
  local rec = T.ok(replay.load(file))
  local chunks = #rec.index:summary().chunks
  T.ok(chunks >= 8, "a recording of many chunks: " .. chunks)
  -- the first chunk (the first line, /world/sig's first message) and the last (the last line)
  T.eq(rec.index:chunks_read(), 2, "opening read two of " .. chunks .. " chunks")
  T.eq(rec.root, "main")
  T.eq({ rec.model.lines[1].line, rec.model.lines[2].line }, { "main.a: running", "main: DONE" })
  T.eq(#rec.series, 1)
  local s = rec.series[1]
  T.eq(s.name, "/world/sig")
  T.eq(s.fields, { "x", "y[0]", "y[1]", "pad" })  -- (a text field reads 0, as the live topics)
  T.eq(rec.index:chunks_read(), 2, "no rows read yet")
  local rows = s.rows
  T.eq(rec.index:chunks_read(), 2 + chunks, "the rows: every chunk of /world/sig, once")
  -- thinned evenly to MAX_ROWS: every 4th of 20000 samples
  T.eq(#rows, replay.MAX_ROWS)
  for k = 1, #rows, 499 do
    local i = 1 + 4 * (k - 1)
    T.eq(rows[k], { i / 100, i, 2 * i, 3 * i, 0 }, "row " .. k)
  end
end)

suite:case("a_file_that_is_no_mcap_is_refused_with_its_name", function()
  local file = T.write(T.tmpname(".mcap"), "not a recording")
  local rec, err = replay.load(file)
  T.eq(rec, nil)
  T.contains(err, file)
end)

-- A file damaged in its middle (a chunk's bytes overwritten) opens (its summary and the chunks it needs are
-- whole); the rows stop at the damaged chunk, said on stderr, and nothing is raised. A file cut short is no
-- indexed file: it is read whole, and refused with its name.
suite:case("a_damaged_chunk_ends_the_rows_and_a_cut_file_is_refused", function()
  local file = recording(20000)
  local bytes = T.read(file)
  local mid = #bytes // 2
  T.write(file, bytes:sub(1, mid) .. ("\255"):rep(64) .. bytes:sub(mid + 65))
  local rec = T.ok(replay.load(file))
  local rows = rec.series[1].rows
  T.ok(#rows > 0 and #rows < replay.MAX_ROWS, "the rows before the damaged chunk: " .. #rows)
  T.write(file, bytes:sub(1, #bytes - 100))
  local none, err = replay.load(file)
  T.eq(none, nil)
  T.contains(err, file)
end)

return suite:run(...)
