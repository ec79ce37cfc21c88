-- `dca trace diff A B`: the first divergence of two traces of runs in simulated time (`dca run --trace`).
local trace = require "dca.trace"

local M = {}

M.summary = "compare two traces of runs in simulated time (dca run --trace): the first divergence"
M.usage = [[usage: dca trace diff A B

Compares two traces written by `dca run --trace FILE` (one line per output sample digest, set switch, event
and transition, sorted by tick) and prints the first divergence: the tick, the process and port, and both
lines with their values. Exit code 0 when the traces are identical, 1 when they differ, 2 on bad usage or a
file that cannot be read.]]

function M.main(args)
  if args[1] ~= "diff" or not args[2] or not args[3] or args[4] then
    io.stderr:write(M.usage, "\n")
    return 2
  end
  local d, err = trace.diff(args[2], args[3])
  if err then io.stderr:write("dca trace: ", err, "\n") return 2 end
  if not d then print("identical: " .. args[2] .. " and " .. args[3]) return 0 end
  print(d)
  return 1
end

return M
