/*
 * peer_fastdds: a ROS 2 peer on Fast DDS 2.9 (the library rmw_fastrtps_cpp uses) with its own
 * hand-written copy of the types: TopicDataType classes that serialize with Fast CDR as
 * rmw_fastrtps's type support does (plain CDR, little endian, no padding after the last member).
 * The command line and the lines printed are those of peer_cyclone (tests/ros2peer/README.md).
 *
 * A subscriber prints the serialized payload as it arrived, then decoded; it reports each
 * matched writer's type name, QoS and USER_DATA from discovery (a writer is reported once both
 * its discovery data and its match are in). A publisher waits for matched readers, writes one
 * value and waits for the acknowledgements. Endpoints carry "typehash=RIHS01_...;" in USER_DATA
 * and the participant "enclave=/;", as ROS 2 Iron and later nodes do.
 *
 * It never picks a network by itself: the participant comes from the "ros2peer" profile of
 * --config FILE or of FASTRTPS_DEFAULT_PROFILES_FILE (tests/ros2peer/fastdds.xml: UDPv4 only,
 * limited to 127.0.0.1, initial peer 127.0.0.1, no built-in transports).
 */
#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastcdr/exceptions/Exception.h>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <fastdds/rtps/common/InstanceHandle.h>
#include <fastdds/rtps/common/SerializedPayload.h>

#include "peer_common.h"

namespace fdds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;
namespace fcdr = eprosima::fastcdr;

namespace {

const char *const PROFILE = "ros2peer";         // the participant profile of the XML file
const uint32_t ENCAPSULATION_LEN = 4;           // CDR_LE + options, before the data
const uint32_t SCALAR_LEN = 8;                  // Int64, Float64
// First reservation of an unbounded type's payload; PREALLOCATED_WITH_REALLOC grows it.
const uint32_t UNBOUNDED_RESERVE = 512;

// ---- the types, as rosidl_typesupport_fastrtps_cpp lays them out ----

struct Time {
        int32_t sec = 0;
        uint32_t nanosec = 0;
};

struct Header {
        Time stamp;
        std::string frame_id;
};

struct KeyValue {
        std::string key, value;
};

struct DiagnosticStatus {
        uint8_t level = 0;
        std::string name, message, hardware_id;
        std::vector<KeyValue> values;
};

struct DiagnosticArray {
        Header header;
        std::vector<DiagnosticStatus> status;
};

struct NavSatFix {
        Header header;
        int8_t status = 0;                      // NavSatStatus.status
        uint16_t service = 0;                   // NavSatStatus.service
        double latitude = 0, longitude = 0, altitude = 0;
        std::array<double, PEER_COVARIANCE_LEN> position_covariance{};
        uint8_t position_covariance_type = 0;
};

// One sample of any of the types (the topic's type says which member counts), and the
// serialized payload it was read from.
struct Sample {
        int64_t i = 0;
        double d = 0;
        std::string s;
        DiagnosticArray diag;
        NavSatFix fix;
        std::vector<unsigned char> cdr;
};

void put(fcdr::Cdr &c, const Header &h)
{
        c << h.stamp.sec << h.stamp.nanosec << h.frame_id;
}

void get(fcdr::Cdr &c, Header &h)
{
        c >> h.stamp.sec >> h.stamp.nanosec >> h.frame_id;
}

// A sequence length no payload of len bytes can hold is refused before anything is allocated.
uint32_t get_length(fcdr::Cdr &c, size_t len)
{
        uint32_t n;

        c >> n;
        if (n > len)
                throw fcdr::exception::NotEnoughMemoryException("sequence longer than payload");
        return n;
}

void put(fcdr::Cdr &c, enum peer_type t, const Sample &s)
{
        switch (t) {
        case PEER_INT64:
                c << s.i;
                break;
        case PEER_FLOAT64:
                c << s.d;
                break;
        case PEER_STRING:
                c << s.s;
                break;
        case PEER_DIAGNOSTIC_ARRAY:
                put(c, s.diag.header);
                c << static_cast<uint32_t>(s.diag.status.size());
                for (const DiagnosticStatus &st : s.diag.status) {
                        c << st.level << st.name << st.message << st.hardware_id;
                        c << static_cast<uint32_t>(st.values.size());
                        for (const KeyValue &kv : st.values)
                                c << kv.key << kv.value;
                }
                break;
        case PEER_NAVSATFIX:
                put(c, s.fix.header);
                c << s.fix.status << s.fix.service << s.fix.latitude << s.fix.longitude
                  << s.fix.altitude;
                c.serializeArray(s.fix.position_covariance.data(), PEER_COVARIANCE_LEN);
                c << s.fix.position_covariance_type;
                break;
        default:
                break;
        }
}

void get(fcdr::Cdr &c, enum peer_type t, Sample &s, size_t len)
{
        switch (t) {
        case PEER_INT64:
                c >> s.i;
                break;
        case PEER_FLOAT64:
                c >> s.d;
                break;
        case PEER_STRING:
                c >> s.s;
                break;
        case PEER_DIAGNOSTIC_ARRAY:
                get(c, s.diag.header);
                s.diag.status.resize(get_length(c, len));
                for (DiagnosticStatus &st : s.diag.status) {
                        c >> st.level >> st.name >> st.message >> st.hardware_id;
                        st.values.resize(get_length(c, len));
                        for (KeyValue &kv : st.values)
                                c >> kv.key >> kv.value;
                }
                break;
        case PEER_NAVSATFIX:
                get(c, s.fix.header);
                c >> s.fix.status >> s.fix.service >> s.fix.latitude >> s.fix.longitude
                  >> s.fix.altitude;
                c.deserializeArray(s.fix.position_covariance.data(), PEER_COVARIANCE_LEN);
                c >> s.fix.position_covariance_type;
                break;
        default:
                break;
        }
}

class PeerType : public fdds::TopicDataType {
public:
        explicit PeerType(enum peer_type t) : type_(t)
        {
                setName(peer_type_dds_name(t));
                m_typeSize = ENCAPSULATION_LEN +
                        (t == PEER_INT64 || t == PEER_FLOAT64 ? SCALAR_LEN : UNBOUNDED_RESERVE);
                m_isGetKeyDefined = false;
                // rmw_fastrtps sends no XTypes type object or information; neither do we.
                auto_fill_type_object(false);
                auto_fill_type_information(false);
        }

        bool serialize(void *data, rtps::SerializedPayload_t *payload) override
        {
                fcdr::FastBuffer fb(reinterpret_cast<char *>(payload->data), payload->max_size);
                fcdr::Cdr c(fb, fcdr::Cdr::DEFAULT_ENDIAN, fcdr::Cdr::DDS_CDR);

                payload->encapsulation = c.endianness() == fcdr::Cdr::BIG_ENDIANNESS ? CDR_BE
                                                                                      : CDR_LE;
                try {
                        c.serialize_encapsulation();
                        put(c, type_, *static_cast<Sample *>(data));
                } catch (fcdr::exception::Exception &) {
                        return false;
                }
                payload->length = static_cast<uint32_t>(c.getSerializedDataLength());
                return true;
        }

        bool deserialize(rtps::SerializedPayload_t *payload, void *data) override
        {
                Sample *s = static_cast<Sample *>(data);
                fcdr::FastBuffer fb(reinterpret_cast<char *>(payload->data), payload->length);
                fcdr::Cdr c(fb, fcdr::Cdr::DEFAULT_ENDIAN, fcdr::Cdr::DDS_CDR);

                s->cdr.assign(payload->data, payload->data + payload->length);
                try {
                        c.read_encapsulation();
                        get(c, type_, *s, payload->length);
                } catch (fcdr::exception::Exception &) {
                        return false;
                }
                return true;
        }

        std::function<uint32_t()> getSerializedSizeProvider(void *data) override
        {
                return [this, data]() -> uint32_t {
                        fcdr::FastBuffer fb;    // grows as needed
                        fcdr::Cdr c(fb, fcdr::Cdr::DEFAULT_ENDIAN, fcdr::Cdr::DDS_CDR);

                        c.serialize_encapsulation();
                        put(c, type_, *static_cast<Sample *>(data));
                        return static_cast<uint32_t>(c.getSerializedDataLength());
                };
        }

        void *createData() override
        {
                return new Sample();
        }

        void deleteData(void *data) override
        {
                delete static_cast<Sample *>(data);
        }

        bool getKey(void *, rtps::InstanceHandle_t *, bool) override
        {
                return false;           // no keys: one instance per topic, as in ROS
        }

private:
        enum peer_type type_;
};

// ---- Sample <-> the neutral value ----

int to_value(enum peer_type t, const Sample &s, struct peer_value *v)
{
        bool ok = true;
        auto dup = [&ok](const std::string &str) {
                char *p = peer_strdup(str.c_str());

                ok = ok && p;
                return p;
        };
        const Header *h = t == PEER_NAVSATFIX ? &s.fix.header : &s.diag.header;

        v->type = t;
        v->i = s.i;
        v->d = s.d;
        if (t == PEER_STRING)
                v->s = dup(s.s);
        if (t == PEER_DIAGNOSTIC_ARRAY || t == PEER_NAVSATFIX) {
                v->sec = h->stamp.sec;
                v->nanosec = h->stamp.nanosec;
                v->frame_id = dup(h->frame_id);
        }
        if (t == PEER_DIAGNOSTIC_ARRAY && !s.diag.status.empty()) {
                v->status = static_cast<struct peer_status *>(
                        calloc(s.diag.status.size(), sizeof(*v->status)));
                if (!v->status)
                        return -ENOMEM;
                for (const DiagnosticStatus &st : s.diag.status) {
                        struct peer_status *o = &v->status[v->n_status++];

                        o->level = st.level;
                        o->name = dup(st.name);
                        o->message = dup(st.message);
                        o->hardware_id = dup(st.hardware_id);
                        o->values = static_cast<struct peer_kv *>(
                                calloc(st.values.size() + 1, sizeof(*o->values)));
                        if (!o->values)
                                return -ENOMEM;
                        for (const KeyValue &kv : st.values) {
                                o->values[o->n_values].key = dup(kv.key);
                                o->values[o->n_values++].value = dup(kv.value);
                        }
                }
        }
        if (t == PEER_NAVSATFIX) {
                v->fix_status = s.fix.status;
                v->service = s.fix.service;
                v->latitude = s.fix.latitude;
                v->longitude = s.fix.longitude;
                v->altitude = s.fix.altitude;
                memcpy(v->covariance, s.fix.position_covariance.data(), sizeof(v->covariance));
                v->covariance_type = s.fix.position_covariance_type;
        }
        return ok ? 0 : -ENOMEM;
}

void from_value(const struct peer_value *v, Sample &s)
{
        Header &h = v->type == PEER_NAVSATFIX ? s.fix.header : s.diag.header;

        s.i = v->i;
        s.d = v->d;
        s.s = v->s ? v->s : "";
        h.stamp.sec = v->sec;
        h.stamp.nanosec = v->nanosec;
        h.frame_id = v->frame_id ? v->frame_id : "";
        for (size_t i = 0; i < v->n_status; i++) {
                const struct peer_status *st = &v->status[i];
                DiagnosticStatus o;

                o.level = st->level;
                o.name = st->name;
                o.message = st->message;
                o.hardware_id = st->hardware_id;
                for (size_t k = 0; k < st->n_values; k++)
                        o.values.push_back(KeyValue{ st->values[k].key, st->values[k].value });
                s.diag.status.push_back(o);
        }
        s.fix.status = v->fix_status;
        s.fix.service = v->service;
        s.fix.latitude = v->latitude;
        s.fix.longitude = v->longitude;
        s.fix.altitude = v->altitude;
        memcpy(s.fix.position_covariance.data(), v->covariance, sizeof(v->covariance));
        s.fix.position_covariance_type = v->covariance_type;
}

// ---- listeners: everything they learn goes through one mutex to the main thread ----

struct WriterInfo {
        std::string type_name;
        bool reliable, transient_local;
        std::vector<unsigned char> user_data;
};

struct State {
        const struct peer_args *a = nullptr;
        std::mutex m;
        std::condition_variable cv;
        int readers = 0;                        // pub: matched readers now
        int got = 0;                            // sub: samples printed
        bool bad_sample = false;
        std::map<rtps::GUID_t, WriterInfo> discovered;
        std::set<rtps::GUID_t> matched, reported;

        // Prints a writer once both its discovery data and its match are known (m held).
        void report(const rtps::GUID_t &g)
        {
                auto d = discovered.find(g);

                if (d == discovered.end() || !matched.count(g) || reported.count(g))
                        return;
                reported.insert(g);
                peer_print_writer(a->topic, d->second.type_name.c_str(), d->second.reliable,
                                  d->second.transient_local, d->second.user_data.data(),
                                  d->second.user_data.size());
        }
};

class ParticipantListener : public fdds::DomainParticipantListener {
public:
        explicit ParticipantListener(State &s) : s_(s) {}

        void on_publisher_discovery(fdds::DomainParticipant *,
                                    rtps::WriterDiscoveryInfo &&info) override
        {
                const rtps::WriterProxyData &w = info.info;
                std::lock_guard<std::mutex> lock(s_.m);

                if (info.status != rtps::WriterDiscoveryInfo::DISCOVERED_WRITER ||
                    w.topicName().to_string() != s_.a->topic)
                        return;
                s_.discovered[w.guid()] = WriterInfo{
                        w.typeName().to_string(),
                        w.m_qos.m_reliability.kind == fdds::RELIABLE_RELIABILITY_QOS,
                        w.m_qos.m_durability.kind == fdds::TRANSIENT_LOCAL_DURABILITY_QOS,
                        std::vector<unsigned char>(w.m_qos.m_userData.data_vec().begin(),
                                                   w.m_qos.m_userData.data_vec().end()) };
                s_.report(w.guid());
        }

private:
        State &s_;
};

class ReaderListener : public fdds::DataReaderListener {
public:
        explicit ReaderListener(State &s) : s_(s) {}

        void on_subscription_matched(fdds::DataReader *,
                                     const fdds::SubscriptionMatchedStatus &st) override
        {
                std::lock_guard<std::mutex> lock(s_.m);
                rtps::GUID_t g = rtps::iHandle2GUID(st.last_publication_handle);

                if (st.current_count_change > 0) {
                        s_.matched.insert(g);
                        s_.report(g);
                } else {
                        s_.matched.erase(g);
                }
        }

        void on_data_available(fdds::DataReader *reader) override
        {
                Sample sample;
                fdds::SampleInfo info;

                while (reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
                        struct peer_value v = {};
                        std::lock_guard<std::mutex> lock(s_.m);

                        if (!info.valid_data)
                                continue;
                        if (to_value(s_.a->type, sample, &v) == 0) {
                                peer_print_sample(s_.a->topic, peer_type_dds_name(s_.a->type),
                                                  sample.cdr.data(), sample.cdr.size(), &v);
                        } else {
                                s_.bad_sample = true;
                        }
                        peer_value_free(&v);
                        s_.got++;
                        sample = Sample();
                        s_.cv.notify_all();
                }
        }

private:
        State &s_;
};

class WriterListener : public fdds::DataWriterListener {
public:
        explicit WriterListener(State &s) : s_(s) {}

        void on_publication_matched(fdds::DataWriter *,
                                    const fdds::PublicationMatchedStatus &st) override
        {
                std::lock_guard<std::mutex> lock(s_.m);

                s_.readers = st.current_count;
                s_.cv.notify_all();
        }

private:
        State &s_;
};

// ---- entities ----

template <typename Qos> void set_endpoint_qos(const struct peer_args &a, Qos &q)
{
        const char *ud = peer_type_user_data(a.type);

        q.reliability().kind = a.reliable ? fdds::RELIABLE_RELIABILITY_QOS
                                          : fdds::BEST_EFFORT_RELIABILITY_QOS;
        q.durability().kind = a.transient_local ? fdds::TRANSIENT_LOCAL_DURABILITY_QOS
                                                : fdds::VOLATILE_DURABILITY_QOS;
        q.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
        q.history().depth = a.depth;
        q.endpoint().history_memory_policy = rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
        q.user_data().data_vec(std::vector<rtps::octet>(ud, ud + strlen(ud)));
}

// The participant from the "ros2peer" profile of --config FILE or of the file Fast DDS loaded
// from FASTRTPS_DEFAULT_PROFILES_FILE; neither is refused rather than falling back to Fast DDS's
// default (multicast discovery on every interface).
fdds::DomainParticipant *create_participant(const struct peer_args &a,
                                           fdds::DomainParticipantListener *listener)
{
        fdds::DomainParticipantFactory *f = fdds::DomainParticipantFactory::get_instance();
        fdds::DomainParticipantQos q;
        const char *env = getenv("FASTRTPS_DEFAULT_PROFILES_FILE");

        if (!a.config && !(env && *env)) {
                fprintf(stderr, "peer_fastdds: no network configuration: pass --config "
                        "tests/ros2peer/fastdds.xml or set FASTRTPS_DEFAULT_PROFILES_FILE\n");
                return nullptr;
        }
        if (a.config && f->load_XML_profiles_file(a.config) != ReturnCode_t::RETCODE_OK) {
                fprintf(stderr, "peer_fastdds: %s: not a Fast DDS profiles file\n", a.config);
                return nullptr;
        }
        if (f->get_participant_qos_from_profile(PROFILE, q) != ReturnCode_t::RETCODE_OK) {
                fprintf(stderr, "peer_fastdds: no participant profile \"%s\"\n", PROFILE);
                return nullptr;
        }
        q.user_data().data_vec(std::vector<rtps::octet>(
                PEER_PARTICIPANT_USER_DATA,
                PEER_PARTICIPANT_USER_DATA + strlen(PEER_PARTICIPANT_USER_DATA)));
        return f->create_participant(a.domain, q, listener,
                                     fdds::StatusMask::none());
}

std::chrono::steady_clock::time_point deadline(const struct peer_args &a)
{
        return std::chrono::steady_clock::now() + std::chrono::milliseconds(a.timeout_ms);
}

int run_sub(const struct peer_args &a, State &s, fdds::DomainParticipant *p, fdds::Topic *topic)
{
        ReaderListener listener(s);
        fdds::DataReaderQos q = fdds::DATAREADER_QOS_DEFAULT;
        fdds::Subscriber *sub = p->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
        fdds::DataReader *r;
        auto end = deadline(a);

        set_endpoint_qos(a, q);
        r = sub ? sub->create_datareader(topic, q, &listener) : nullptr;
        if (!r) {
                fprintf(stderr, "peer_fastdds: reader failed\n");
                return PEER_EXIT_FAIL;
        }
        peer_print_line("ready sub topic=%s type=%s", a.topic, peer_type_dds_name(a.type));
        std::unique_lock<std::mutex> lock(s.m);
        bool done = s.cv.wait_until(lock, end, [&] {
                return s.bad_sample || (a.count > 0 && s.got >= a.count);
        });
        int got = s.got;
        bool bad = s.bad_sample;
        lock.unlock();
        // The reader goes before its listener does.
        r->set_listener(nullptr);
        sub->delete_datareader(r);
        if (bad) {
                fprintf(stderr, "peer_fastdds: a sample that does not decode\n");
                return PEER_EXIT_FAIL;
        }
        if (!done && a.count > 0) {
                fprintf(stderr, "peer_fastdds: timeout: %d of %d samples\n", got, a.count);
                return PEER_EXIT_FAIL;
        }
        return PEER_EXIT_OK;
}

int run_pub(const struct peer_args &a, State &s, fdds::DomainParticipant *p, fdds::Topic *topic)
{
        WriterListener listener(s);
        fdds::DataWriterQos q = fdds::DATAWRITER_QOS_DEFAULT;
        fdds::Publisher *pub = p->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
        fdds::DataWriter *w;
        struct peer_value v;
        Sample sample;
        auto end = deadline(a);
        int rc = PEER_EXIT_FAIL;

        if (peer_value_parse(a.type, a.value, &v) < 0) {
                fprintf(stderr, "peer_fastdds: not a %s value: %s\n", peer_type_ros_name(a.type),
                        a.value);
                return PEER_EXIT_USAGE;
        }
        from_value(&v, sample);
        set_endpoint_qos(a, q);
        w = pub ? pub->create_datawriter(topic, q, &listener) : nullptr;
        if (!w) {
                fprintf(stderr, "peer_fastdds: writer failed\n");
                peer_value_free(&v);
                return PEER_EXIT_FAIL;
        }
        peer_print_line("ready pub topic=%s type=%s", a.topic, peer_type_dds_name(a.type));
        {
                std::unique_lock<std::mutex> lock(s.m);

                if (!s.cv.wait_until(lock, end, [&] { return s.readers >= a.readers; })) {
                        fprintf(stderr, "peer_fastdds: timeout: %d of %d readers matched\n",
                                s.readers, a.readers);
                        goto out;
                }
                peer_print_line("matched readers=%d", s.readers);
        }
        // Once, or (--wait-stdin) once for each line on stdin until its end.
        for (int n = 0;; n++) {
                if (a.wait_stdin && peer_wait_stdin() < 0) {
                        if (n == 0) {
                                fprintf(stderr, "peer_fastdds: end of input, nothing written\n");
                                goto out;
                        }
                        break;
                }
                if (!w->write(&sample)) {
                        fprintf(stderr, "peer_fastdds: write failed\n");
                        goto out;
                }
                printf("wrote topic=%s type=%s value=", a.topic, peer_type_dds_name(a.type));
                peer_value_print(stdout, &v);
                peer_print_line("%s", "");
                if (!a.wait_stdin)
                        break;
        }
        {
                eprosima::fastrtps::Duration_t t(a.timeout_ms / 1000,
                                                 (uint32_t)(a.timeout_ms % 1000) * 1000000u);

                if (w->wait_for_acknowledgments(t) != ReturnCode_t::RETCODE_OK) {
                        fprintf(stderr, "peer_fastdds: timeout waiting for acknowledgements\n");
                        goto out;
                }
        }
        peer_print_line("acked");
        if (a.hold)
                peer_hold_stdin();
        rc = PEER_EXIT_OK;
out:
        w->set_listener(nullptr);
        pub->delete_datawriter(w);
        peer_value_free(&v);
        return rc;
}

} // namespace

int main(int argc, char **argv)
{
        struct peer_args a;
        State s;
        int rc;

        if (peer_args_parse(argc, argv, &a) < 0)
                return PEER_EXIT_USAGE;
        s.a = &a;
        ParticipantListener pl(s);
        fdds::DomainParticipant *p = create_participant(a, &pl);
        if (!p)
                return PEER_EXIT_USAGE;
        // The participant listener hears only discovery (on_publisher_discovery is not a status).
        fdds::TypeSupport type(new PeerType(a.type));
        type.register_type(p);
        fdds::Topic *topic = p->create_topic(a.topic, peer_type_dds_name(a.type),
                                            fdds::TOPIC_QOS_DEFAULT);
        if (!topic) {
                fprintf(stderr, "peer_fastdds: topic %s failed\n", a.topic);
                rc = PEER_EXIT_FAIL;
        } else {
                rc = a.cmd == PEER_SUB ? run_sub(a, s, p, topic) : run_pub(a, s, p, topic);
        }
        p->set_listener(nullptr);
        p->delete_contained_entities();
        fdds::DomainParticipantFactory::get_instance()->delete_participant(p);
        return rc;
}
