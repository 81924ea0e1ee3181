"""The VLM perception source: find an object by a text label, the way a rate-limited vision-language model
would, and hold its pose in the map frame.

source      the PerceptionSource (entry points ``vlm`` and ``vlm_stub``): budget, worker thread, consensus,
            latch, circuit breaker
latch       consensus of a few answers → a pose held in the anchor frame, and the circuit breaker
client      what the source asks of a model (VlmClient) and how the configured client is chosen
stub        ColourShapeClient, the colour-and-shape stand-in for a model (``client: stub``)
gemini, openai_chat, remote   the remote clients and the manners they share
families    model families (gemini-er, qwen2.5-vl, qwen3-vl, molmo, molmo2, generic): each one's prompt and
            answer reader; pointing  the Gemini-form reader they share
quota       the call budget (rate limit, daily quota) persisted across restarts
depth_pose  a pixel and the depth image → a 6-DoF surface pose

Kept in one package because only the VLM source uses these; nothing here imports the other plugins.
"""
