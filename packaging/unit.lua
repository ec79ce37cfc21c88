-- Writes the package's dca-daemon.service (the unit `dca deploy` writes for a host, with the host's options taken
-- from /etc/default/dca-daemon): dca lua packaging/unit.lua OUT   (run by packaging/CMakeLists.txt)
local out = assert(..., "usage: dca lua unit.lua OUT")
local f = assert(io.open(out, "w"))
f:write(require("dca.deploy").unit(nil, "dca-daemon.service of the dca package: this host's daemon (docs/deploy.md)"))
f:close()
