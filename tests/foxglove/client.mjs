// A Foxglove WebSocket client for tests/foxglove: Foxglove's own @foxglove/ws-protocol, on `ws`.
//
// usage: node client.mjs URL PLAN_JSON [SUBPROTOCOL]
//
// Runs the plan's steps in order and prints one JSON object on stdout: the server's info, its
// channels and services, every message received (topic, log time in ns, base64 payload), the
// latest time broadcast, service responses and failures, and the message count at each "mark".
// Steps ({"op": ...}):
//   subscribe {topics}                     wait until they are advertised, subscribe to them
//   advertise {topic, encoding, schemaName} a client channel, to publish on
//   publish {topic, json|text|base64, repeat?} send on an advertised client channel
//   call {service, encoding, base64?|text?} call a service and wait for its answer
//   waitFor {topic, count, timeoutMs?}     until `count` messages of `topic` arrived
//   getParameters {names}; setParameters {parameters}  the values the server answers with
//   sleep {ms}; mark {}; abortMidMessage {} (send half a frame, then drop the connection)
// The subprotocol must be foxglove.sdk.v1 for foxglove-sdk's server; with another one the server
// answers HTTP <status>, which is printed as {"httpStatus": status}.
import wsProtocol from "@foxglove/ws-protocol";
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;
const [url, planText, subprotocol = "foxglove.sdk.v1"] = process.argv.slice(2);
const plan = JSON.parse(planText);
const out = { channels: [], services: [], messages: [], responses: [], failures: [], marks: [] };
const channelsByTopic = new Map();
const topicOfSubscription = new Map();
const clientChannels = new Map();
const servicesByName = new Map();
let serviceAnswered = null;

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));
const b64 = (bytes) => Buffer.from(bytes.buffer, bytes.byteOffset, bytes.byteLength).toString("base64");
const count = (topic) => out.messages.filter((m) => m.topic === topic).length;

async function until(predicate, timeoutMs, what) {
  const end = Date.now() + timeoutMs;
  while (!predicate()) {
    if (Date.now() > end) throw new Error(`timed out after ${timeoutMs} ms waiting for ${what}`);
    await sleep(5);
  }
}

function payload(step) {
  if (step.json !== undefined) return new TextEncoder().encode(JSON.stringify(step.json));
  if (step.text !== undefined) return new TextEncoder().encode(step.text);
  return new Uint8Array(Buffer.from(step.base64 ?? "", "base64"));
}

async function run(client, ws) {
  for (const step of plan) {
    if (step.op === "subscribe") {
      await until(() => step.topics.every((t) => channelsByTopic.has(t)), 5000, step.topics);
      for (const topic of step.topics) {
        topicOfSubscription.set(client.subscribe(channelsByTopic.get(topic).id), topic);
      }
    } else if (step.op === "advertise") {
      const { topic, encoding, schemaName } = step;
      clientChannels.set(topic, client.advertise({ topic, encoding, schemaName }));
    } else if (step.op === "publish") {
      const data = payload(step);
      for (let i = 0; i < (step.repeat ?? 1); i++) client.sendMessage(clientChannels.get(step.topic), data);
    } else if (step.op === "call") {
      await until(() => servicesByName.has(step.service), 5000, step.service);
      const callId = out.responses.length + out.failures.length + 1;
      serviceAnswered = false;
      const { id } = servicesByName.get(step.service);
      client.sendServiceCallRequest({ serviceId: id, callId, encoding: step.encoding, data: payload(step) });
      await until(() => serviceAnswered, 5000, `an answer from ${step.service}`);
    } else if (step.op === "getParameters") {
      out.parameters = undefined;
      client.getParameters(step.names ?? [], "get");
      await until(() => out.parameters !== undefined, 5000, "the parameters");
    } else if (step.op === "setParameters") {
      out.parameters = undefined;
      client.setParameters(step.parameters, "set");
      await until(() => out.parameters !== undefined, 5000, "the parameters after a set");
    } else if (step.op === "waitFor") {
      await until(() => count(step.topic) >= step.count, step.timeoutMs ?? 10000, `${step.count} on ${step.topic}`);
    } else if (step.op === "sleep") {
      await sleep(step.ms);
    } else if (step.op === "mark") {
      out.marks.push(out.messages.length);
    } else if (step.op === "abortMidMessage") {
      // A masked binary frame that announces 1000 bytes, of which 10 are sent before the socket
      // goes away: the server sees a client vanish in the middle of a message.
      const header = Buffer.from([0x82, 0x80 | 126, 0x03, 0xe8, 1, 2, 3, 4]);
      ws._socket.write(Buffer.concat([header, Buffer.alloc(10, 7)]));
      ws._socket.destroy();
      return;
    } else {
      throw new Error(`unknown step ${JSON.stringify(step)}`);
    }
  }
}

const ws = new WebSocket(url, [subprotocol]);
ws.on("unexpected-response", (_request, response) => {
  process.stdout.write(JSON.stringify({ httpStatus: response.statusCode }) + "\n", () => process.exit(0));
});
const client = new FoxgloveClient({ ws });
client.on("serverInfo", (info) => (out.serverInfo = info));
client.on("advertise", (channels) => {
  for (const channel of channels) {
    channelsByTopic.set(channel.topic, channel);
    out.channels.push(channel);
  }
});
client.on("advertiseServices", (services) => {
  for (const service of services) {
    servicesByName.set(service.name, service);
    out.services.push(service);
  }
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  out.messages.push({ topic: topicOfSubscription.get(subscriptionId), t: String(timestamp), data: b64(data) });
});
client.on("time", ({ timestamp }) => (out.time = String(timestamp)));
client.on("parameterValues", ({ parameters }) => (out.parameters = parameters));
client.on("serviceCallResponse", (response) => {
  out.responses.push({ encoding: response.encoding, data: b64(response.data) });
  serviceAnswered = true;
});
client.on("serviceCallFailure", (failure) => {
  out.failures.push(failure);
  serviceAnswered = true;
});
let opened = false;
client.on("error", (error) => {
  console.error(`client error: ${error}`);
  if (!opened) report({ ...out, error: String(error) }, 1); // never connected
});
// Exit once stdout is flushed (a pipe takes large reports in several writes).
const report = (value, status) => {
  client.close();
  process.stdout.write(JSON.stringify(value) + "\n", () => process.exit(status));
};
client.on("open", async () => {
  opened = true;
  try {
    await run(client, ws);
    report(out, 0);
  } catch (error) {
    report({ ...out, error: String(error) }, 1);
  }
});
