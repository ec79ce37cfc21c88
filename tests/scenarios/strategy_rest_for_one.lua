-- The rest_for_one strategy, in memory and with real processes: tests/scenarios/lib/strategy.lua.
return dofile((os.getenv("DCA_SOURCE_DIR") or ".") .. "/tests/scenarios/lib/strategy.lua")("rest_for_one")
