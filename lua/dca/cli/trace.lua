-- `dca trace diff A B`: the first divergence of two traces of runs in simulated time (`dca run --trace`).
local trace = require "dca.trace"

local M = {}

M.summary = "compare two traces of runs in simulated time (dca run --trace): the first divergence"
M.usage = [[usage: dca trace diff A B
       dca trace diff REC.mcap NEW.mcap

Compares two traces written by `dca run --trace FILE` (one line per output sample digest, set switch, event
and transition, sorted by tick) and prints the first divergence: the tick, the process and port, and both
lines with their values. Exit code 0 when the traces are identical, 1 when they differ, 2 on bad usage or a
file that cannot be read.

Two MCAP recordings (`dca run --record FILE.mcap --record-ports ...`, e.g. a run and its replay with
`--replay REC.mcap`) are compared channel by channel, every channel both hold but the run's lines: the
first tick where a port's message differs (or one recording has a message the other lacks), the channel and
both messages.]]

function M.main(args)
  if args[1] ~= "diff" or not args[2] or not args[3] or args[4] then
    io.stderr:write(M.usage, "\n")
    return 2
  end
  if args[2]:match("%.mcap$") and args[3]:match("%.mcap$") then
    local d, same = trace.diff_recordings(args[2], args[3])
    if d == false then io.stderr:write("dca trace: ", same, "\n") return 2 end
    print(d or same)
    return d and 1 or 0
  end
  local d, err = trace.diff(args[2], args[3])
  if err then io.stderr:write("dca trace: ", err, "\n") return 2 end
  if not d then print("identical: " .. args[2] .. " and " .. args[3]) return 0 end
  print(d)
  return 1
end

return M
