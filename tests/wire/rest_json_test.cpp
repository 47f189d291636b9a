// The REST JSON of every request and reply (wire/rest_json.h): what one side
// writes the other reads back as the same message, a few documents are the
// contract's byte for byte, and a malformed field is refused naming it.
#include <gtest/gtest.h>
#include <google/protobuf/util/message_differencer.h>

#include <cmath>
#include <limits>

#include "wire/rest_json.h"

namespace mm::wire {
namespace {

using google::protobuf::util::MessageDifferencer;

v1::Motion motion(int frames, int columns, float first) {
  v1::Motion m;
  m.set_frames(frames);
  m.set_columns(columns);
  m.set_frame_rate(25);
  m.set_layout("h36m-expmap-99");
  for (int i = 0; i < frames * columns; ++i) m.add_values(first + 0.1f * static_cast<float>(i));
  return m;
}

v1::Code code(float first, int length = 4) {
  v1::Code c;
  for (int i = 0; i < length; ++i) c.add_values(first - 0.37f * static_cast<float>(i));
  return c;
}

v1::AnsweredBy answered_by() {
  v1::AnsweredBy a;
  a.set_model("h36m-dkgm-h100");
  a.set_version("0123456789abcdef");
  return a;
}

v1::TakeWindow window(double start_seconds, int64_t start_frame, float first) {
  v1::TakeWindow w;
  w.set_start_seconds(start_seconds);
  w.set_start_frame(start_frame);
  *w.mutable_code() = code(first);
  return w;
}

v1::JobSpec job_spec() {
  v1::JobSpec spec;
  spec.set_dataset("h3.6m/dataset");
  spec.set_variant("DK");
  spec.set_config_json(R"({"batch":4,"model":{"hidden":16}})");
  spec.set_iterations(20);
  spec.set_seed(18446744073709551615ull);
  spec.set_hidden(16);
  spec.set_batch(4);
  spec.set_model_name("mine");
  return spec;
}

v1::Job job(const std::string& id) {
  v1::Job j;
  j.set_id(id);
  *j.mutable_spec() = job_spec();
  j.set_state("running");
  auto* p = j.mutable_progress();
  p->set_iteration(7);
  p->set_total(20);
  (*p->mutable_losses())["total"] = 1.25;
  (*p->mutable_losses())["kl"] = 0.5;
  p->set_iterations_per_second(3.5);
  p->set_eta_seconds(4);
  j.set_error("");
  j.set_published_model("");
  j.set_created_at(1764150000.125);
  j.set_started_at(1764150001.5);
  j.set_resumes(1);
  j.set_resolved_config_json(R"({"model":{"hidden":16},"variant":"DK"})");
  return j;
}

v1::ModelInfo model_info(const std::string& name) {
  v1::ModelInfo m;
  m.set_name(name);
  m.set_version("fedcba9876543210");
  m.set_active(true);
  m.set_loaded(true);
  m.set_variant("DKGM");
  m.set_hidden(1024);
  m.set_latent(64);
  m.set_frames(150);
  m.set_columns(99);
  m.set_frame_rate(25);
  m.set_layout("h36m-expmap-99");
  m.add_decoders("rotation");
  m.add_decoders("velocity");
  m.set_load_seconds(0.75);
  m.set_precision("int8");
  m.set_provenance_json(R"({"dataset":"h3.6m"})");
  m.set_evaluation_json("{}");
  m.set_model_card("# card\n");
  m.set_skeleton_json(R"({"joints":[],"name":"h36m"})");
  return m;
}

v1::ClipFile clip(const std::string& path) {
  v1::ClipFile c;
  c.set_path(path);
  c.set_format("h36m-text");
  c.set_size_bytes(5000000000);
  c.set_uploaded(true);
  return c;
}

// The message written, its text parsed as a body is, and read back.
template <typename Message>
Message round_trip(const Message& message) {
  Message back;
  from_json(Json::parse(body_text(to_json(message))), back);
  return back;
}

template <typename Message>
void expect_round_trip(const Message& message) {
  const Message back = round_trip(message);
  std::string differences;
  MessageDifferencer differencer;
  differencer.ReportDifferencesToString(&differences);
  EXPECT_TRUE(differencer.Compare(message, back)) << message.GetTypeName() << ": " << differences;
}

// ---- every message reads back as written

TEST(RestJson, EveryRequestReadsBackAsWritten) {
  v1::EncodeRequest encode;
  encode.set_model("h36m-dkgm-h100");
  *encode.add_motions() = motion(3, 2, 0.1f);
  *encode.add_motions() = motion(2, 3, -5.5f);
  expect_round_trip(encode);

  v1::DecodeRequest decode;
  *decode.add_codes() = code(0.25f, 64);
  *decode.add_codes() = code(-1e-30f);
  decode.set_decoder("velocity");
  expect_round_trip(decode);

  v1::SampleRequest sample;
  sample.set_count(3);
  sample.set_seed(18446744073709551615ull);
  sample.set_decoder("rotation");
  expect_round_trip(sample);
  expect_round_trip(v1::SampleRequest());

  v1::InterpolateRequest interpolate;
  interpolate.set_model("m");
  *interpolate.mutable_from()->mutable_motion() = motion(2, 2, 3.0f);
  *interpolate.mutable_to()->mutable_code() = code(1.0f);
  interpolate.set_steps(5);
  interpolate.set_method("spherical");
  interpolate.set_decoder("rotation");
  expect_round_trip(interpolate);

  v1::AnalogyRequest analogy;
  *analogy.mutable_a()->mutable_code() = code(1.0f);
  *analogy.mutable_b()->mutable_motion() = motion(1, 3, 2.0f);
  *analogy.mutable_c()->mutable_code() = code(-1.0f);
  analogy.set_decoder("velocity");
  expect_round_trip(analogy);
  expect_round_trip(v1::AnalogyRequest());  // neither motion nor code: the core names the field

  v1::DenoiseRequest denoise;
  *denoise.add_motions() = motion(2, 4, 0.0f);
  denoise.set_zeros_are_missing(true);
  denoise.set_iterations(3);
  denoise.set_keep_observed(true);
  expect_round_trip(denoise);

  expect_round_trip(job_spec());

  v1::DecodeTrackRequest track;
  track.set_model("m");
  *track.add_windows() = window(0, 0, 0.5f);
  *track.add_windows() = window(3.04, 0, -0.5f);  // start_frame is not sent: 0 reads back as 0
  track.set_frame_rate(29.97);
  track.set_frames(500);
  track.set_decoder("rotation");
  track.set_blend("cut");
  expect_round_trip(track);
}

TEST(RestJson, EveryReplyReadsBackAsWritten) {
  v1::EncodeReply encode;
  *encode.mutable_answered_by() = answered_by();
  *encode.add_codes() = code(0.125f, 64);
  *encode.add_codes() = code(std::numeric_limits<float>::max());
  expect_round_trip(encode);

  v1::MotionsReply motions;
  *motions.mutable_answered_by() = answered_by();
  *motions.add_motions() = motion(3, 3, 0.3f);
  *motions.add_codes() = code(2.0f);
  expect_round_trip(motions);

  expect_round_trip(model_info("h36m-dkgm-h100"));
  v1::ListModelsReply models;
  *models.add_models() = model_info("a");
  *models.add_models() = model_info("b");
  expect_round_trip(models);

  expect_round_trip(clip("h3.6m/dataset/S5/walking_1.txt"));
  v1::ListClipsReply clips;
  *clips.add_clips() = clip("a.txt");
  *clips.add_clips() = clip("b/c.bvh");
  clips.set_truncated(true);
  expect_round_trip(clips);

  v1::ReadClipReply window_reply;
  window_reply.set_path("mine/walk.bvh");
  window_reply.set_format("bvh");
  window_reply.set_start(7);
  window_reply.set_file_frames(9000000000);
  window_reply.set_file_frame_rate(120);
  window_reply.set_last_start(8999999700);
  *window_reply.mutable_motion() = motion(2, 5, 1.5f);
  expect_round_trip(window_reply);

  expect_round_trip(job("job-1"));
  v1::ListJobsReply jobs;
  *jobs.add_jobs() = job("job-2");
  *jobs.add_jobs() = job("job-1");
  expect_round_trip(jobs);

  v1::CodeTrack track;
  *track.mutable_answered_by() = answered_by();
  track.set_frames(9000);
  track.set_frame_rate(50);
  track.set_window_seconds(6);
  track.set_hop_seconds(3);
  *track.add_windows() = window(0, 0, 1.0f);
  *track.add_windows() = window(3, 150, 2.0f);
  expect_round_trip(track);

  TakeReply take;
  *take.header.mutable_answered_by() = answered_by();
  take.header.set_frame_rate(120);
  take.header.set_columns(3);
  take.header.set_layout("expmap-3");
  take.frames.set_frames(2);
  for (float v : {1.0f, 2.5f, -3.25f, 4.0f, 5.0f, 6.0f}) take.frames.add_values(v);
  for (float e : {0.5f, 12.75f}) take.frames.add_error_mm(e);
  take.summary.set_frames(2);
  take.summary.set_input_frames(2);
  take.summary.set_mean_error_mm(6.625);
  take.summary.set_max_error_mm(12.75);
  take.summary.set_window_seconds(6);
  take.summary.set_hop_seconds(3);
  take.summary.set_gap_windows_fitted(1);
  take.summary.set_gaps_fitted(2);
  take.summary.set_gaps_over_fit_limit(3);
  *take.summary.add_windows() = window(0, 0, 1.0f);
  const TakeReply back = round_trip(take);
  EXPECT_TRUE(MessageDifferencer::Equals(take.header, back.header)) << back.header.DebugString();
  EXPECT_TRUE(MessageDifferencer::Equals(take.frames, back.frames)) << back.frames.DebugString();
  EXPECT_TRUE(MessageDifferencer::Equals(take.summary, back.summary)) << back.summary.DebugString();
}

// Every float of a motion reads back as the same float32, extremes included.
TEST(RestJson, FloatsReadBackBitForBit) {
  v1::EncodeRequest request;
  v1::Motion* m = request.add_motions();
  m->set_frames(1);
  for (float v : {0.1f, -0.0f, 1e-45f, 1.17549435e-38f, 3.40282347e38f, 16777217.0f, 0.333333343f, -2.5e-7f}) {
    m->add_values(v);
  }
  m->set_columns(m->values_size());
  const v1::EncodeRequest back = round_trip(request);
  ASSERT_EQ(back.motions(0).values_size(), m->values_size());
  for (int i = 0; i < m->values_size(); ++i) {
    EXPECT_EQ(std::signbit(back.motions(0).values(i)), std::signbit(m->values(i))) << i;
    EXPECT_EQ(back.motions(0).values(i), m->values(i)) << i;
  }
}

// ---- the contract's documents, byte for byte

TEST(RestJson, EncodeReplyIsWrittenWithShortestFloats) {
  v1::EncodeReply reply;
  *reply.mutable_answered_by() = answered_by();
  v1::Code* c = reply.add_codes();
  for (float v : {0.1f, -2.5f, 3.0f}) c->add_values(v);
  EXPECT_EQ(body_text(to_json(reply)),
            R"({"answered_by":{"model":"h36m-dkgm-h100","version":"0123456789abcdef"},"codes":[[0.1,-2.5,3.0]]})");
}

TEST(RestJson, ModelInfoEmbedsItsJsonTextAsObjects) {
  v1::ModelInfo m = model_info("h36m-dkgm-h100");
  m.set_decoders(1, "rotation2");
  m.set_evaluation_json("");         // empty: an empty object
  m.set_skeleton_json("not json");   // not JSON: null rather than a failed reply
  EXPECT_EQ(body_text(to_json(m)),
            R"({"active":true,"columns":99,"decoders":["rotation","rotation2"],"evaluation":{},"feet":[],"frame_rate":25.0,)"
            R"("frames":150,"hidden":1024,"latent":64,"layout":"h36m-expmap-99","load_seconds":0.75,"loaded":true,)"
            R"("model_card":"# card\n","name":"h36m-dkgm-h100","precision":"int8","provenance":{"dataset":"h3.6m"},)"
            R"("skeleton":null,)"
            R"("trajectory":false,"variant":"DKGM","version":"fedcba9876543210"})");
}

TEST(RestJson, JobIsWrittenWithItsSpecProgressAndTimes) {
  v1::Job j = job("job-1");
  j.mutable_spec()->clear_config_json();  // no configuration: no "config"
  EXPECT_EQ(body_text(to_json(j)),
            R"({"created_at":1764150000.125,"error":"","finished_at":0.0,"id":"job-1",)"
            R"("progress":{"eta_seconds":4.0,"iteration":7,"iterations_per_second":3.5,)"
            R"("losses":{"kl":0.5,"total":1.25},"total":20},"published_model":"",)"
            R"("resolved_config":{"model":{"hidden":16},"variant":"DK"},"resumes":1,)"
            R"("spec":{"batch":4,"dataset":"h3.6m/dataset","hidden":16,"iterations":20,"model_name":"mine",)"
            R"("seed":18446744073709551615,"variant":"DK"},"started_at":1764150001.5,"state":"running"})");
}

// Where the proto's zero means "the default", a request leaves the field
// out: that is how REST asks for the default.
TEST(RestJson, RequestsLeaveOutTheZerosThatMeanTheDefault) {
  v1::SampleRequest sample;
  sample.set_seed(7);
  EXPECT_EQ(body_text(to_json(sample)), R"({"decoder":"","model":"","seed":7})");
  sample.set_count(2);
  EXPECT_EQ(body_text(to_json(sample)), R"({"count":2,"decoder":"","model":"","seed":7})");

  v1::InterpolateRequest interpolate;
  *interpolate.mutable_from()->mutable_code() = code(1.0f, 1);
  EXPECT_EQ(body_text(to_json(interpolate)), R"({"decoder":"","from":{"code":[1.0]},"model":"","to":{}})");

  v1::JobSpec spec;
  spec.set_dataset("tiny");
  EXPECT_EQ(body_text(to_json(spec)),
            R"({"batch":0,"dataset":"tiny","hidden":0,"iterations":0,"model_name":"","seed":0})");
  // A job record writes its variant even when empty.
  v1::Job record;
  *record.mutable_spec() = spec;
  EXPECT_EQ(to_json(record)["spec"]["variant"], "");
}

TEST(RestJson, TakeReplyCarriesTheHeaderFramesSummaryAndWindows) {
  TakeReply take;
  *take.header.mutable_answered_by() = answered_by();
  take.header.set_frame_rate(50);
  take.header.set_columns(2);
  take.header.set_layout("expmap-2");
  take.frames.set_frames(1);
  take.frames.add_values(0.5f);
  take.frames.add_values(-1.0f);
  take.summary.set_frames(1);
  take.summary.set_window_seconds(6);
  take.summary.set_hop_seconds(3);
  *take.summary.add_windows() = window(0.04, 1, 0.25f);
  take.summary.mutable_windows(0)->mutable_code()->mutable_values()->Truncate(1);
  EXPECT_EQ(body_text(to_json(take)),
            R"({"answered_by":{"model":"h36m-dkgm-h100","version":"0123456789abcdef"},"columns":2,"error_mm":[],)"
            R"("frame_rate":50.0,"frames":1,"layout":"expmap-2",)"
            R"("summary":{"frames":1,"gap_windows_fitted":0,"gaps_fitted":0,"gaps_over_fit_limit":0,)"
            R"("hop_seconds":3.0,"input_frames":0,"max_error_mm":0.0,"mean_error_mm":0.0,)"
            R"("window_seconds":6.0},"values":[0.5,-1.0],)"
            R"("windows":[{"code":[0.25],"start_frame":1,"start_seconds":0.04}]})");
}

// ---- refusals name the field, the value and what was expected

std::string refusal(const std::string& body, const std::function<void(const Json&)>& read) {
  try {
    read(Json::parse(body));
  } catch (const InputError& error) {
    return error.field() + ": " + error.detail();
  }
  return "read without a refusal";
}

template <typename Message>
std::function<void(const Json&)> reads() {
  return [](const Json& body) {
    Message message;
    from_json(body, message);
  };
}

TEST(RestJson, AMalformedFieldIsRefusedNamingItsPathValueAndExpectedType) {
  EXPECT_EQ(refusal(R"({"motions": [{}, {}, {"columns": "99"}]})", reads<v1::EncodeRequest>()),
            "motions[2].columns: expected a 32-bit integer, got string");
  EXPECT_EQ(refusal(R"({"motions": [{"values": [1, 2, true]}]})", reads<v1::EncodeRequest>()),
            "motions[0].values[2]: expected a number, got boolean");
  EXPECT_EQ(refusal(R"({"count": 1.5})", reads<v1::SampleRequest>()), "count: expected a 32-bit integer, got 1.5");
  EXPECT_EQ(refusal(R"({"count": 2147483648})", reads<v1::SampleRequest>()),
            "count: expected a 32-bit integer, got number");
  EXPECT_EQ(refusal(R"({"seed": "-1"})", reads<v1::SampleRequest>()),
            "seed: expected a non-negative 64-bit integer (a number or its decimal string), got \"-1\"");
  EXPECT_EQ(refusal(R"({"from": {"motion": {"frames": []}}})", reads<v1::InterpolateRequest>()),
            "from.motion.frames: expected a 32-bit integer, got array");
  EXPECT_EQ(refusal(R"({"a": {"motion": {}, "code": [1]}})", reads<v1::AnalogyRequest>()),
            "a: expected exactly one of motion or code, found both");
  EXPECT_EQ(refusal(R"({"keep_observed": 1})", reads<v1::DenoiseRequest>()),
            "keep_observed: expected a boolean (true or false), got number");
  EXPECT_EQ(refusal(R"({"config": "{}"})", reads<v1::JobSpec>()),
            "config: expected an object (the training configuration), got string");
  EXPECT_EQ(refusal(R"({"windows": [{"code": {}}]})", reads<v1::DecodeTrackRequest>()),
            "windows[0].code: expected an array of numbers, got object");
  EXPECT_EQ(refusal(R"([1])", reads<v1::EncodeRequest>()), ": expected an object, got array");
}

TEST(RestJson, RequestsRefuseUnknownFieldsAndRepliesIgnoreThem) {
  EXPECT_EQ(refusal(R"({"zeros_missing": true})", reads<v1::DenoiseRequest>()),
            "zeros_missing: unknown field; expected one of: decoder, iterations, keep_observed, means_are_missing, "
            "model, motions, zeros_are_missing");
  EXPECT_EQ(refusal(R"({"model": "m"})", [](const Json& body) { empty_from_json(body); }),
            "model: unknown field; this call takes no fields");
  // A newer server's reply with a field this client does not know.
  v1::Job job;
  from_json(Json::parse(R"({"id": "job-1", "resolved_config": {"batch": 4}, "spec": {"dataset": "d", "new": 1}})"),
            job);
  EXPECT_EQ(job.id(), "job-1");
  EXPECT_EQ(job.spec().dataset(), "d");
}

TEST(RestJson, NumbersReadAsProto3JsonAllows) {
  v1::SampleRequest sample;
  from_json(Json::parse(R"({"count": 3.0, "seed": "18446744073709551615", "model": null})"), sample);
  EXPECT_EQ(sample.count(), 3);
  EXPECT_EQ(sample.seed(), 18446744073709551615ull);
  v1::DecodeTrackRequest track;
  from_json(Json::parse(R"({"frame_rate": "NaN", "windows": [{"start_seconds": "-Infinity", "code": [1e300]}]})"),
            track);
  EXPECT_TRUE(std::isnan(track.frame_rate()));
  EXPECT_EQ(track.windows(0).start_seconds(), -std::numeric_limits<double>::infinity());
  EXPECT_EQ(track.windows(0).code().values(0), std::numeric_limits<float>::infinity());
}

}  // namespace
}  // namespace mm::wire
